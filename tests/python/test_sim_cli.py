"""pleat-sim end to end: a tiny t-shirt on the walking body for one step, through the command line."""
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[2]
MOTION = "humanoid3d_walk"


def _have_motion():
    try:
        from pleat.motion import load_clip
        from pleat.sim.scene import load_body
        load_clip(MOTION, body=load_body())
        return True
    except Exception:
        return False


@pytest.mark.skipif(not _have_motion(), reason=f"motion clip {MOTION} not available")
def test_pleat_sim_cli_writes_positions_and_a_truthful_summary(tmp_path):
    from pleat.garment import make_garment
    from pleat.sim import BodyCollider
    from pleat.sim.scene import load_body
    body = load_body()
    garment_path = tmp_path / "tshirt_small.npz"
    make_garment("tshirt", body=body, vertices=500).save(garment_path)
    out = tmp_path / "sim"
    run = subprocess.run([sys.executable, "-m", "pleat.sim.cli", "--garment", str(garment_path), "--motion", MOTION,
                          "--frames", "2", "--out", str(out), "--quiet", "--lead-in", "4", "--hold", "1"], capture_output=True, text=True, timeout=300,
                         cwd=REPO)
    assert run.returncode == 0, run.stderr
    summary = json.loads((out / "summary.json").read_text())
    for key in ("frames", "seconds_per_frame", "max_penetration_mm", "max_penetration_before_projection_mm",
                "final_gradient_norm", "gradient_tolerance", "steps_not_converged", "per_frame"):
        assert key in summary
    assert summary["frames"] == 2
    assert summary["lead_in"]["frames"] == 4 and summary["lead_in"]["hold_frames"] == 1
    assert 0.0 <= summary["substeps_converged_fraction"] <= 1.0
    assert 0.0 < summary["seconds_per_frame"] < 300.0
    assert np.isfinite(summary["final_gradient_norm"]) and summary["final_gradient_norm"] >= 0.0
    assert len(summary["per_frame"]["penetration_after_projection_mm"]) == 1
    assert summary["per_frame"]["substeps"][0] >= 1
    # the faces' share inside the body (pleat.sim.surface), on both frames
    surface = summary["surface_inside"]
    assert surface["frames"] == 2 and 0.0 <= surface["inside_pct"] <= surface["worst_frame_inside_pct"] <= 100.0
    with np.load(out / "sim.npz") as z:
        x = z["positions"].astype(np.float64)
        body_v = z["body_vertices"].astype(np.float64)
        faces = z["faces"]
    assert x.shape[0] == 2 and x.shape[2] == 3 and np.isfinite(x).all()
    assert len(faces) > 0 and faces.max() < x.shape[1]
    # no explosion: in 1/30 s no vertex moves more than the fastest body vertex plus free fall would allow
    body_speed = np.linalg.norm(body_v[1] - body_v[0], axis=1).max()
    assert np.linalg.norm(x[1] - x[0], axis=1).max() < body_speed + 0.05
    # the summary's penetration is what an independent query of the stored frames finds, and within tolerance
    depth_mm = 1000.0 * max(0.0, -BodyCollider(body_v[1], body.faces).plane_distance(x[1]).min())
    assert depth_mm <= summary["penetration_tolerance_mm"]
    assert abs(depth_mm - summary["per_frame"]["penetration_after_projection_mm"][0]) < 0.05
