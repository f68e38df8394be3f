"""Where a training run's independent jobs execute: the simulated segments and the fits (docs/training.md, "Many
garments, many machines").

    Local(workers)        this machine: `map` on a process pool, `run` in forked children (pleat.train.forkpool),
                          which share the parent's gigabytes of sequences copy-on-write; what `pleat-train simsup`
                          uses, and all the base install needs
    Serial()              one after another in this process, torch on one thread as every task runs: the reference
                          a parallel build matches
    RayTasks(address)     Ray tasks (`ray` from PyPI, the `ray` extra): a local Ray started here by default, or the
                          cluster at `address`; what `pleat-wardrobe` uses

Both calls take module-level functions and their arguments (functools.partial for `run`), not closures: Ray puts
each distinct argument object into its object store once, however many tasks share it, where a closure would be
pickled whole for every task. Results come back in the order of the jobs; `map` also hands each result to
`on_result` in the caller as soon as it arrives, so the caller can keep it (the simulation cache) before the slowest
job ends, and a run stopped half-way keeps what was done. The simulation cache stays with the caller
(pleat.train.simdata): a task returns what it simulated and never writes files, so a node of a cluster needs no
shared disk. Every job sets its own seed; Serial and Ray run each on one thread (torch and BLAS, one_cpu), so they
give the same networks bit for bit; Local's forked fits run torch on one thread too, but the simulations and the
driver's own work use the machine's BLAS threads, which can change the last bits.
"""
import contextlib
import functools
import os
import time
from concurrent.futures import ProcessPoolExecutor, as_completed

from pleat.train import forkpool


@contextlib.contextmanager
def one_cpu():
    """torch and the BLAS under numpy on one thread, as a task of one CPU runs: the thread count changes how some
    sums are split (an SVD, a matrix product), so a job gives the same result only at the same count."""
    import torch
    from threadpoolctl import threadpool_limits
    threads = torch.get_num_threads()
    torch.set_num_threads(1)
    try:
        with threadpool_limits(1):
            yield
    finally:
        torch.set_num_threads(threads)


# ---- this machine ---------------------------------------------------------------------------------------------------
_CONTEXT = {}


def _arrived(on_result, k, result):
    if on_result is not None:
        on_result(k, result)


def _pool_init(context):
    os.environ.setdefault("NUMBA_NUM_THREADS", "1")
    _CONTEXT["value"] = context


def _call(fn, context, item, deadline):
    """fn(context, item), or None past `deadline` (time.time(); None: no deadline)."""
    if deadline is not None and time.time() > deadline:
        return None
    return fn(context, item)


def _pool_call(fn, item, deadline):
    return _call(fn, _CONTEXT["value"], item, deadline)


class Local:
    """This machine's processes: `workers` at a time."""
    name = "local"

    def __init__(self, workers=1):
        self.workers = max(1, int(workers))

    def map(self, fn, context, items, deadline=None, on_result=None):
        """[fn(context, item) for item in items], None for an item not started before `deadline` (time.time());
        `context` (read-only, large) goes to each worker process once. on_result(k, result) runs here as item k
        finishes, in the order they finish."""
        results = [None] * len(items)
        with ProcessPoolExecutor(max_workers=self.workers, initializer=_pool_init, initargs=(context,)) as pool:
            futures = {pool.submit(_pool_call, fn, item, deadline): k for k, item in enumerate(items)}
            for future in as_completed(futures):
                k = futures[future]
                results[k] = future.result()
                _arrived(on_result, k, results[k])
        return results

    def run(self, jobs):
        """[job() for job in jobs], `workers` at a time in forked children."""
        return forkpool.run(jobs, self.workers)


class Serial:
    """One job after another in this process, torch on one thread: what a parallel run reproduces bit for bit."""
    name = "serial"
    workers = 1

    def map(self, fn, context, items, deadline=None, on_result=None):
        results = []
        with one_cpu():
            for k, item in enumerate(items):
                results.append(_call(fn, context, item, deadline))
                _arrived(on_result, k, results[k])
        return results

    def run(self, jobs):
        with one_cpu():
            return [job() for job in jobs]


# ---- Ray -------------------------------------------------------------------------------------------------------------
def _ray():
    try:
        import ray
    except ImportError:
        from pleat.cli import InputError
        raise InputError(None, "Ray is not installed: PLEAT_EXTRAS=train,ray scripts/setup.sh (or pip install ray)")
    return ray


def _ray_map_task(fn, context, item, deadline):
    with one_cpu():
        return _call(fn, context, item, deadline)


def _ray_run_task(fn, *args, **kwargs):
    with one_cpu():
        return fn(*args, **kwargs)


class RayTasks:
    """Ray tasks of one CPU each. address None: a local Ray started here with `cpus` CPUs (default all), stopped by
    close(); else the running cluster at `address` ("auto", "ray://host:10001", host:port), left running."""
    name = "ray"

    def __init__(self, address=None, cpus=None, object_store_mb=None):
        ray = _ray()
        self.ray, self.started = ray, False
        if not ray.is_initialized():
            kw = dict(log_to_driver=False, include_dashboard=False, configure_logging=False)
            if address is None:
                kw.update(num_cpus=cpus)
                if object_store_mb:
                    kw.update(object_store_memory=int(object_store_mb) * 2 ** 20)
            ray.init(address=address, **{k: v for k, v in kw.items() if v is not None})
            self.started = True
        self.workers = max(1, int(ray.cluster_resources().get("CPU", 1)))
        self._map = ray.remote(num_cpus=1)(_ray_map_task)
        self._run = ray.remote(num_cpus=1)(_ray_run_task)

    def close(self):
        if self.started and self.ray.is_initialized():
            self.ray.shutdown()
        self.started = False

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def map(self, fn, context, items, deadline=None, on_result=None):
        ref = self.ray.put(context)
        futures = [self._map.remote(fn, ref, item, deadline) for item in items]
        index = {future: k for k, future in enumerate(futures)}
        results, pending = [None] * len(items), list(futures)
        while pending:
            ready, pending = self.ray.wait(pending, num_returns=1)
            k = index[ready[0]]
            results[k] = self.ray.get(ready[0])
            _arrived(on_result, k, results[k])
        return results

    def run(self, jobs):
        """Each job a task; a functools.partial's arguments go into the object store once per distinct object."""
        put = {}

        def ref(value):
            if isinstance(value, (int, float, str, bool, type(None))):
                return value
            if id(value) not in put:
                put[id(value)] = (self.ray.put(value), value)   # keeps `value` alive: ids stay unique
            return put[id(value)][0]

        futures = []
        for job in jobs:
            if isinstance(job, functools.partial):
                args = [ref(a) for a in job.args]
                kwargs = {k: ref(v) for k, v in job.keywords.items()}
                futures.append(self._run.remote(job.func, *args, **kwargs))
            else:
                futures.append(self._run.remote(job))
        return self.ray.get(futures)

