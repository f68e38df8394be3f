"""Writing output files so that a failed write never destroys the file that was there.

Everything a tool writes goes to a temporary file in the target's own folder (same file system, so the rename is
atomic), is flushed and fsynced, and only then renamed over the target with os.replace. If anything fails first —
the serializer raises, the disk is full, the process is killed — the target still holds its old contents (or still
does not exist) and the temporary file is removed. The new file gets the old file's permission bits, or the usual
0666 & ~umask for a new one (mkstemp alone would leave 0600).

    with atomic_write("out/report.json", "w") as fh:     # text or binary file object
        json.dump(report, fh)
    write_bytes(path, data); write_text(path, text); save_npz(path, compressed=True, **arrays)
    save_figure(fig, "plot.png", dpi=80)
"""
import os
import stat
import tempfile
from contextlib import contextmanager
from pathlib import Path

import numpy as np


def _default_mode():
    mask = os.umask(0)
    os.umask(mask)
    return 0o666 & ~mask


@contextmanager
def atomic_write(path, mode="wb", encoding="utf-8"):
    """A file object for `path` ("wb" or "w"); the target is replaced only when the block ends without error."""
    if mode not in ("w", "wb"):
        raise ValueError(f"atomic_write mode must be 'w' or 'wb', not {mode!r}")
    path = Path(path)
    folder = path.parent if str(path.parent) else Path(".")
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=folder)
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

