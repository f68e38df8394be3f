"""Validation clips re-expressed the way another mocap source could express them (docs/accuracy.md, "Motion from a
skeleton unlike the training data's"): not a test, a probe of how the shipped model generalises.

The training motion (DeepMimic) has one chest joint, spread evenly over spine1..3, and no collars (always the
identity). A source with a real spine and clavicles differs in both. Per clip this writes Pleat clip npz files
(exact, no retargeting) for pleat-eval-suite --clips:
  <clip>_spine.npz   the chest's rotation split 0.5 / 0.3 / 0.2 over spine1..3 (the same total rotation);
  <clip>_collar<s>.npz  a share s (default a quarter) of each shoulder's rotation moved into its collar
                     (Clip.with_collar_share: the arm keeps its orientation relative to the chest; the shoulder
                     joint moves with the collar, as it does on a real body);
  <clip>_ood.npz     both;
  <clip>_noise<d>.npz  with --noise-deg d: every joint's and the root's rotation turned by a random axis and an
                     angle ~ N(0, d°) each frame, the root moved by N(0, d mm) per axis: the frame-to-frame jitter
                     of optical or inertial capture that a cleaned dataset like DeepMimic's does not have.

    PYTHONPATH=tools .venv/bin/python bench/reexpress_clips.py --out out/ood deepmimic_github/humanoid3d_jog ...
    PLEAT_LIBRARY=build/eval/libpleat.so pleat-eval-suite --assets assets/tshirt.pleat --clips out/ood/*.npz \
        --betas 0 --out out/suite_ood.json
"""
import argparse
from dataclasses import replace
from pathlib import Path

import numpy as np

from pleat.motion.clip import _quat_power
from pleat.motion.loaders import load_clip_at
from pleat.rotations import quat_multiply, quat_normalize

SPINE_SPLIT = (0.5, 0.3, 0.2)
COLLAR_SHARE = 0.25    # as the "collar" training variant (pleat.train.simdata); --collar-share probes others


def reexpress(clip, spine=True, collar=COLLAR_SHARE):
    names = list(clip.joint_names)
    q = clip.local_rotations.copy()
    if spine:
        s1, s2, s3 = (names.index(n) for n in ("spine1", "spine2", "spine3"))
        total = quat_multiply(quat_multiply(q[:, s1], q[:, s2]), q[:, s3])
        for k, share in zip((s1, s2, s3), SPINE_SPLIT):
            q[:, k] = _quat_power(total, share)
    clip = replace(clip, local_rotations=q)
    return clip.with_collar_share(collar) if collar else clip


def _random_turns(rng, shape, sigma_rad):
    axis = rng.normal(size=shape + (3,))
    axis /= np.linalg.norm(axis, axis=-1, keepdims=True)
    half = 0.5 * rng.normal(scale=sigma_rad, size=shape)[..., None]
    return np.concatenate([axis * np.sin(half), np.cos(half)], -1)


def with_capture_noise(clip, deg, seed=0):
    """White per-frame noise: each joint's local rotation and the root's turned by N(0, deg°) about a random axis,
    the root translated by N(0, deg mm) per axis (1° at a 0.5 m limb is about 9 mm at its end)."""
    rng = np.random.default_rng(seed)
    sigma = np.radians(deg)
    q = quat_normalize(quat_multiply(clip.local_rotations, _random_turns(rng, clip.local_rotations.shape[:2], sigma)))
    root = quat_normalize(quat_multiply(clip.root_rotation, _random_turns(rng, clip.root_rotation.shape[:1], sigma)))
    move = rng.normal(scale=deg * 1e-3, size=clip.root_translation.shape)
    return replace(clip, local_rotations=q, root_rotation=root, root_translation=clip.root_translation + move)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("clips", nargs="+", help="clip names or files")
    ap.add_argument("--out", required=True, help="output folder")
    ap.add_argument("--frames", type=int, default=60, help="frames per clip at 30 fps (default 60)")
    ap.add_argument("--collar-share", type=float, default=COLLAR_SHARE,
                    help="share of the shoulder's rotation moved into the collar (default 0.25)")
    ap.add_argument("--noise-deg", type=float, default=0.0,
                    help="write only <clip>_noise<d>.npz: capture noise of d degrees (and d mm at the root)")
    a = ap.parse_args(argv)
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    for name in a.clips:
        clip = load_clip_at(name, fps=30.0, max_frames=a.frames)
        stem = Path(name).name.split(".")[0]
        share = a.collar_share
        if a.noise_deg > 0:
            path = out / f"{stem}_noise{a.noise_deg:g}.npz"
            with_capture_noise(clip, a.noise_deg).save(path)
            print(path)
            continue
        for tag, spine, collar in (("spine", True, 0.0), (f"collar{share:g}", False, share), ("ood", True, share)):
            path = out / f"{stem}_{tag}.npz"
            reexpress(clip, spine, collar).save(path)
            print(path)


if __name__ == "__main__":
    main()
