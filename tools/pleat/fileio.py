"""Writing output files so that a failed write never destroys the file that was there.

Everything a tool writes goes to a temporary file in the target's own folder (same file system, so the rename is
atomic), is flushed and fsynced, and only then renamed over the target with os.replace. If anything fails first —
the serializer raises, the disk is full, the process is killed — the target still holds its old contents (or still
does not exist) and the temporary file is removed. The new file gets the old file's permission bits, or the usual
0666 & ~umask for a new one (mkstemp alone would leave 0600).

A writer killed outright (SIGKILL, power loss) runs no cleanup and leaves its temporary file, `.NAME.PID.XXXXXXXX.tmp`
beside the target NAME, PID being the writer's process id. The rule that clears them: every write of NAME first removes
the temporaries of NAME whose writer process is gone (no process with that id on this machine), and those without a
PID in their name (an older writer's `.NAME.XXXXXXXX.tmp`) that are older than the running process. A temporary of a
writer that is still running is never touched, nor one of another target.

    with atomic_write("out/report.json", "w") as fh:     # text or binary file object
        json.dump(report, fh)
    write_bytes(path, data); write_text(path, text); save_npz(path, compressed=True, **arrays); save_torch(path, obj)
    save_figure(fig, "plot.png", dpi=80)
"""
import os
import re
import stat
import tempfile
import time
from contextlib import contextmanager
from pathlib import Path

import numpy as np


def _default_mode():
    mask = os.umask(0)
    os.umask(mask)
    return 0o666 & ~mask


# This module's import time stands for the process's start: a temporary without a writer id that is older than this
# cannot belong to a write that this process or one started after it is doing.
_PROCESS_START_S = time.time()
# What follows ".NAME." in a temporary's name: "PID.XXXXXXXX.tmp", or "XXXXXXXX.tmp" from before the PID was in it
# (mkstemp's eight characters).
_TEMPORARY_TAIL = re.compile(r"(?:(\d+)\.)?[a-z0-9_]{8}\.tmp")


def _writer_is_gone(pid):
    if pid == os.getpid():
        return False                    # another thread's write of the same target
    if os.name != "posix":
        return False                    # no harmless probe there (os.kill would end the process)
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return True
    except OSError:                     # EPERM: alive, someone else's
        return False
    return False


def remove_stale_temporaries(path):
    """Removes the temporaries a killed writer left for `path` (the rule in the module's docstring). Returns the
    names removed; never raises for a file it cannot remove."""
    path = Path(path)
    folder = path.parent if str(path.parent) else Path(".")
    prefix = f".{path.name}."
    removed = []
    try:
        entries = list(os.scandir(folder))
    except OSError:
        return removed
    for entry in entries:
        if not entry.name.startswith(prefix):
            continue
        tail = _TEMPORARY_TAIL.fullmatch(entry.name[len(prefix):])
        if tail is None:
            continue
        try:
            if tail.group(1) is not None:
                stale = _writer_is_gone(int(tail.group(1)))
            else:
                stale = entry.stat(follow_symlinks=False).st_mtime < _PROCESS_START_S
            if stale and entry.is_file(follow_symlinks=False):
                os.unlink(entry.path)
                removed.append(entry.name)
        except (OSError, ValueError):
            pass
    return removed


@contextmanager
def atomic_write(path, mode="wb", encoding="utf-8"):
    """A file object for `path` ("wb" or "w"); the target is replaced only when the block ends without error. First
    removes the temporaries that killed writers left for `path` (module docstring)."""
    if mode not in ("w", "wb"):
        raise ValueError(f"atomic_write mode must be 'w' or 'wb', not {mode!r}")
    path = Path(path)
    folder = path.parent if str(path.parent) else Path(".")
    remove_stale_temporaries(path)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.{os.getpid()}.", suffix=".tmp", dir=folder)
    try:
        with os.fdopen(fd, mode, **({} if "b" in mode else {"encoding": encoding, "newline": ""})) as fh:
            yield fh
            fh.flush()
            os.fsync(fh.fileno())
        try:
            bits = stat.S_IMODE(os.stat(path).st_mode)
        except FileNotFoundError:
            bits = _default_mode()
        os.chmod(tmp, bits)
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except FileNotFoundError:
            pass
        raise


def write_bytes(path, data):
    with atomic_write(path, "wb") as fh:
        fh.write(data)


def write_text(path, text, encoding="utf-8"):
    with atomic_write(path, "w", encoding) as fh:
        fh.write(text)


def npz_path(path):
    """numpy's own rule: np.savez adds .npz to a file name that lacks it."""
    path = Path(path)
    return path if path.suffix == ".npz" else path.with_name(path.name + ".npz")


def save_npz(path, compressed=False, **arrays):
    """np.savez / np.savez_compressed, atomically; like numpy, adds .npz when `path` lacks it. Returns the path."""
    path = npz_path(path)
    with atomic_write(path, "wb") as fh:
        (np.savez_compressed if compressed else np.savez)(fh, **arrays)
    return path


def save_torch(path, obj):
    """torch.save, atomically (a checkpoint half written when the run is killed would fail its resume)."""
    import torch
    with atomic_write(path, "wb") as fh:
        torch.save(obj, fh)
    return Path(path)


def save_figure(fig, path, **kw):
    """fig.savefig, atomically (the format from the suffix, as savefig does for a path)."""
    path = Path(path)
    kw.setdefault("format", path.suffix[1:].lower() or "png")
    with atomic_write(path, "wb") as fh:
        fig.savefig(fh, **kw)
    return path


def finish_figure(fig, path, **kw):
    """The end of a chart: tight layout, save_figure, the figure closed. Returns the path."""
    import matplotlib.pyplot as plt
    fig.tight_layout()
    path = save_figure(fig, path, **kw)
    plt.close(fig)
    return path

