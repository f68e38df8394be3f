"""Where an asset's garment is still inside the body after the runtime's body contact (docs/accuracy.md, "Candidates
chosen where the cloth was"): not a test, a diagnosis. For every vertex-frame inside the posed body (the simulator's
measure: the tangent plane at the nearest body vertex) it says whether that nearest body vertex is one of the
vertex's contact candidates, another vertex of the same body part (the joint with the largest skin weight), or one of
another part, with the depths and the most common (candidate part, nearest part) pairs.

usage: PLEAT_LIBRARY=build/eval/libpleat.so PYTHONPATH=tools .venv/bin/python bench/contact_misses.py ASSET CLIP ...
"""
import sys
from pathlib import Path

import numpy as np
from scipy.spatial import cKDTree

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tools"))

from pleat import runtime  # noqa: E402
from pleat.asset import NO_CANDIDATE  # noqa: E402
from pleat.body import BodyCollider, BodyModel  # noqa: E402
from pleat.eval import scene as S  # noqa: E402


def main(asset, clips, frames=60):
    body = BodyModel.load()
    names = list(body.joint_names)
    part = np.asarray(body.weights).argmax(1)
    data, w = S.read_weights(asset)
    cand = np.asarray(w["body_anchor_candidates"]).astype(np.int64)
    _, point_vertex = cKDTree(body.v_template).query(np.asarray(w["body_anchor"], np.float64))
    kinds = {"candidate": [], "same part": [], "other part": []}
    pairs, total = {}, 0
    with runtime.Context() as ctx:
        for name in clips:
            clip = S.load_motion(name, body, S.EVAL_FPS, frames)
            beta = np.zeros(len(w["shape_blend"]))
            x = S.clip_rollout(ctx, data, w, clip, beta).positions
            posed, _ = S.posed_body(body, clip, beta)
            for t in range(len(x)):
                collider = BodyCollider(posed[t], body.faces)
                d = collider.plane_distance(np.asarray(x[t], np.float64))
                _, nearest = collider.tree.query(np.asarray(x[t], np.float64))
                total += len(d)
                for i in np.flatnonzero(d < 0):
                    own = point_vertex[cand[i][cand[i] != NO_CANDIDATE]]
                    j = nearest[i]
                    kind = "candidate" if j in own else "same part" if part[j] in part[own] else "other part"
                    kinds[kind].append(-1e3 * d[i])
                    if kind == "other part":
                        key = (names[part[own[0]]], names[part[j]])
                        pairs[key] = pairs.get(key, 0) + 1
    inside = sum(len(v) for v in kinds.values())
    print(f"{asset}: {inside} of {total} vertex-frames inside ({100.0 * inside / total:.2f} %)")
    for kind, depths in kinds.items():
        if depths:
            print(f"  nearest body vertex {kind}: {len(depths)}, depth median {np.median(depths):.1f} mm, "
                  f"p90 {np.percentile(depths, 90):.1f} mm")
    print("  other part, (candidates' part, nearest's part):",
          sorted(pairs.items(), key=lambda kv: -kv[1])[:10])


if __name__ == "__main__":
    if len(sys.argv) < 3:
        sys.exit(__doc__)
    main(sys.argv[1], sys.argv[2:])
