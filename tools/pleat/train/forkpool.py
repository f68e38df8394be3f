"""Independent fits side by side: each job runs in a forked child process, so the parent's data (the simulated
sequences, gigabytes) is shared copy-on-write instead of pickled; only the job's result comes back, through a pipe.
The simulator-supervised recipe's fits (the first fit's members, each round of students) are independent and seeded,
so on two cores two of them at a time give the same networks as one after another in half the wall time
(docs/training-speed.md, "Fits side by side"). Each child runs torch on one thread.
"""
import multiprocessing as mp
import pickle
import traceback
from multiprocessing.connection import wait


def one_thread():
    """torch on one thread in this process (a child's or a task's CPU is its only one)."""
    try:
        import torch
    except ImportError:
        return
    torch.set_num_threads(1)


def _child(job, conn):
    # Plain pickle into bytes, not Connection.send: torch registers reducers on multiprocessing's pickler that pass
    # tensors as file descriptors shared by a server thread of the sender, which is gone once the child exits.
    try:
        one_thread()
        message = pickle.dumps(("ok", job()), protocol=pickle.HIGHEST_PROTOCOL)
    except BaseException:       # the parent re-raises it with the child's traceback
        message = pickle.dumps(("error", traceback.format_exc()))
    try:
        conn.send_bytes(message)
    finally:
        conn.close()


def run(jobs, workers):
    """The results of `jobs` (zero-argument callables) in order, at most `workers` at a time in forked children;
    workers <= 1 (or one job): one after another in this process."""
    if workers <= 1 or len(jobs) <= 1:
        return [job() for job in jobs]
    ctx = mp.get_context("fork")
    results, running, next_job = [None] * len(jobs), {}, 0
    while next_job < len(jobs) or running:
        while next_job < len(jobs) and len(running) < workers:
            receive, send = ctx.Pipe(duplex=False)
            proc = ctx.Process(target=_child, args=(jobs[next_job], send))
            proc.start()
            send.close()
            running[next_job] = (proc, receive)
            next_job += 1
        ready = wait([conn for _, conn in running.values()])
        for k, (proc, conn) in list(running.items()):
            if conn not in ready:
                continue
            try:
                status, value = pickle.loads(conn.recv_bytes())
            except EOFError:
                status, value = "error", f"the child process of job {k} died (exit code {proc.exitcode})"
            proc.join()
            del running[k]
            if status == "error":
                for other, _ in running.values():
                    other.terminate()
                raise RuntimeError(f"forkpool: job {k} failed:\n{value}")
            results[k] = value
    return results


def deadline(t0, end, k, count, workers):
    """Job k's share of the budget [t0, end] when `count` jobs run `workers` at a time (None: no budget)."""
    if end is None:
        return None
    waves = -(-count // max(1, workers))
    return t0 + (end - t0) * (k // max(1, workers) + 1) / waves
