"""Atomic writes: pleat-pack, the ONNX export, Clip.save and pleat-eval's report go through
pleat.fileio, so a write that fails part-way leaves the file that was there untouched and no temporary file behind.

The end-to-end cases fail the write for real: a child process lowers RLIMIT_FSIZE below the new file's size, so the
kernel refuses the write with EFBIG half-way, as a full disk would. Written in place, the old file would already be
truncated by then."""
import json
import os
import re
import stat
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from pleat import asset as pa
from pleat import fileio
from pleat.reference.golden import random_weights

REPO = Path(__file__).resolve().parents[2]
LIMIT_BYTES = 4096      # smaller than every new file below, larger than nothing the child needs to write


def test_a_failing_writer_keeps_the_old_file_and_leaves_no_temporary(tmp_path):
    target = tmp_path / "report.json"
    target.write_text('{"old": true}')
    with pytest.raises(RuntimeError):
        with fileio.atomic_write(target, "w") as fh:
            fh.write('{"new": ')
            raise RuntimeError("serializer failed half-way")
    assert target.read_text() == '{"old": true}'
    assert [p.name for p in tmp_path.iterdir()] == ["report.json"]


def test_a_failing_fsync_keeps_the_old_file(tmp_path, monkeypatch):
    target = tmp_path / "a.bin"
    target.write_bytes(b"old")

    def no_space(fd):
        raise OSError(28, "No space left on device")
    monkeypatch.setattr(os, "fsync", no_space)
    with pytest.raises(OSError):
        fileio.write_bytes(target, b"new contents")
    assert target.read_bytes() == b"old" and [p.name for p in tmp_path.iterdir()] == ["a.bin"]


def test_a_successful_write_replaces_the_file_and_keeps_its_permissions(tmp_path):
    target = tmp_path / "a.bin"
    target.write_bytes(b"old")
    os.chmod(target, 0o640)
    fileio.write_bytes(target, b"new")
    assert target.read_bytes() == b"new" and stat.S_IMODE(target.stat().st_mode) == 0o640
    fresh = tmp_path / "fresh.txt"
    fileio.write_text(fresh, "x")
    mask = os.umask(0)
    os.umask(mask)
    assert stat.S_IMODE(fresh.stat().st_mode) == 0o666 & ~mask, "a new file gets the umask's mode, not mkstemp's 0600"
    assert fileio.save_npz(tmp_path / "c", a=np.arange(3)) == tmp_path / "c.npz", "adds .npz like numpy"


def _run_limited(setup, action, cwd):
    """Runs `setup`, lowers the file-size limit to LIMIT_BYTES, runs `action` in a child Python."""
    limit = f"resource.setrlimit(resource.RLIMIT_FSIZE, ({LIMIT_BYTES}, resource.getrlimit(resource.RLIMIT_FSIZE)[1]))"
    code = "import resource, signal, sys\nsignal.signal(signal.SIGXFSZ, signal.SIG_IGN)\n" + textwrap.dedent(setup) + \
        "\n" + limit + "\n" + textwrap.dedent(action)
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120, cwd=cwd)


@pytest.fixture()
def weights_file(tmp_path):
    path = tmp_path / "w.npz"
    pa.save_weights(path, random_weights(vertices=100, latent=8, blend=6, lp_hidden=(24, 16), dec_hidden=(12,),
                                         seed=11))
    return path


def test_pleat_pack_that_fails_to_write_keeps_the_old_asset(tmp_path, weights_file):
    old = pa.write_asset(None, random_weights(vertices=40, latent=4, blend=2, lp_hidden=(8,), dec_hidden=(8,), seed=1))
    target = tmp_path / "a.pleat"
    target.write_bytes(old)
    run = _run_limited("from pleat import pack", f"sys.exit(pack.main([{str(weights_file)!r}, '--out', "
                                                 f"{str(target)!r}]))", REPO)
    assert run.returncode == 1, run.stderr
    lines = run.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("pleat-pack: error: ") and "File too large" in lines[0]
    assert target.read_bytes() == old
    pa.read_asset(target.read_bytes())      # still a valid asset
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.pleat", "w.npz"]


def test_onnx_export_that_fails_to_write_keeps_the_old_models(tmp_path, weights_file):
    pytest.importorskip("onnx")
    from pleat import onnx_export
    folder = tmp_path / "ox"
    old_paths = onnx_export.export(pa.validate_weights(random_weights(vertices=40, latent=4, blend=2, lp_hidden=(8,),
                                                                      dec_hidden=(8,), seed=1)), folder)
    old = {p.name: p.read_bytes() for p in old_paths}
    run = _run_limited("from pleat import pack", f"sys.exit(pack.main([{str(weights_file)!r}, '--export-onnx', "
                                                 f"{str(folder)!r}]))", REPO)
    assert run.returncode == 1, run.stderr
    assert {p.name: p.read_bytes() for p in folder.iterdir()} == old


def test_clip_save_that_fails_to_write_keeps_the_old_clip(tmp_path):
    from pleat.motion.clip import Clip, identity_clip
    target = tmp_path / "walk.npz"
    identity_clip(3).save(target)
    old = target.read_bytes()
    run = _run_limited(f"""
        import numpy as np
        from pleat.motion.clip import Clip
        rng = np.random.default_rng(0)
        q = rng.normal(size=(60, 24, 4))
        clip = Clip(name="big", fps=30, local_rotations=q / np.linalg.norm(q, axis=-1, keepdims=True),
                    root_translation=rng.normal(size=(60, 3)), root_rotation=np.tile([0, 0, 0, 1.0], (60, 1)))
        """, f"""
        try:
            clip.save({str(target)!r})
        except OSError as exc:
            sys.exit(f"failed: {{exc}}")
        """, REPO)
    assert run.returncode == 1 and "File too large" in run.stderr, run.stderr
    assert target.read_bytes() == old and Clip.load(target).num_frames == 3
    assert [p.name for p in tmp_path.iterdir()] == ["walk.npz"]


def test_pleat_eval_that_fails_to_write_its_report_keeps_the_old_one(tmp_path):
    target = tmp_path / "report.json"
    target.write_text(json.dumps({"old": True}))
    scores = dict(mean_mm=1.0, p95_mm=2.0, penetration_pct=0.0, max_depth_mm=0.0, step_us=10.0)
    run = _run_limited(f"""
        from pleat.eval import cli
        def canned(*args, **kwargs):
            return dict(frames=300, pleat=dict({scores!r}), lbs=dict({scores!r}), teacher=None,
                        reference_spread=None, per_frame=dict(pleat=dict(error_mm=list(range(3000)))))
        cli.evaluate = canned
        """, f"sys.exit(cli.main(['--asset', 'a.pleat', '--motion', 'walk', '--out', {str(target)!r}, "
             "'--per-frame']))", REPO)
    assert run.returncode == 1, run.stderr
    assert run.stderr.startswith("pleat-eval: error: ") and len(run.stderr.strip().splitlines()) == 1
    assert json.loads(target.read_text()) == {"old": True}
    assert [p.name for p in tmp_path.iterdir()] == ["report.json"]


def _temporaries(folder):
    return sorted(p.name for p in folder.iterdir() if p.name.endswith(".tmp"))


def test_the_next_write_removes_the_temporary_a_killed_writer_left(tmp_path):
    """A writer killed mid-write (SIGKILL: no cleanup runs) leaves its hidden temporary file; the next write of the same
    target removes it. A temporary of a writer that is still running, and one of another target, stay."""
    target = tmp_path / "tshirt.pleat"
    target.write_bytes(b"old")
    killed = textwrap.dedent(f"""
        import os, signal, sys
        sys.path.insert(0, {str(REPO / "tools")!r})
        from pleat import fileio
        with fileio.atomic_write({str(target)!r}, "wb") as fh:
            fh.write(b"half an asset")
            fh.flush()
            os.kill(os.getpid(), signal.SIGKILL)
    """)
    child = subprocess.Popen([sys.executable, "-c", killed])
    child.wait()
    left = _temporaries(tmp_path)
    assert len(left) == 1 and left[0].startswith(".tshirt.pleat."), left
    assert target.read_bytes() == b"old"
    # One from a writer of the same target that is still running (this test's parent process: alive, not us), and
    # one that the killed writer left for another target whose name starts the same way.
    live = tmp_path / f".tshirt.pleat.{os.getppid()}.abcd1234.tmp"
    live.write_bytes(b"being written")
    other = tmp_path / f".tshirt.pleat.bak.{child.pid}.abcd1234.tmp"
    other.write_bytes(b"another target")

    fileio.write_bytes(target, b"new")
    assert target.read_bytes() == b"new"
    assert _temporaries(tmp_path) == sorted([live.name, other.name])


# Files whose writes may bypass pleat.fileio, and why.
DIRECT_WRITERS = {
    "pleat/fileio.py": "the atomic writer itself",
    "pleat/sim/crosscheck.py": "its newton side runs in newton's own virtual environment, where pleat is not installed",
}
DIRECT_WRITE = re.compile(r"\bnp\.savez(_compressed)?\(|\btorch\.save\(|(?<!fileio)\.write_(text|bytes)\(")


def test_every_tool_writes_its_files_through_fileio():
    """A tool killed mid-write must not leave a torn file behind (pleat.fileio); a direct np.savez / torch.save /
    Path.write_text / write_bytes in the tools would."""
    from pleat import REPO_ROOT
    root = REPO_ROOT / "tools"
    found = []
    for path in sorted(root.rglob("*.py")):
        rel = path.relative_to(root).as_posix()
        if rel in DIRECT_WRITERS or "/tests/" in rel:
            continue
        for k, line in enumerate(path.read_text().splitlines(), 1):
            if DIRECT_WRITE.search(line.split("#")[0]):
                found.append(f"{rel}:{k}: {line.strip()}")
    assert not found, ("write through pleat.fileio (atomic_write, write_text, save_npz, save_torch):\n" +
                       "\n".join(found))
