"""pleat-wardrobe on Ray (pleat.train.wardrobe, pleat.train.tasks): a local two-node Ray cluster started by the test
(ray.cluster_utils.Cluster, one CPU per node) builds a garment and a tier from the tiny preset, and gives the same
networks, bit for bit, as the serial path in this process; its simulations, run as tasks that write no file, fill
the caller's cache with the same frames. Needs torch and ray (PLEAT_EXTRAS=train,ray; CI's `ray` stage)."""
import importlib.util
import json

import numpy as np
import pytest

pytest.importorskip("torch")

from pleat.eval import scene as S  # noqa: E402
from pleat.train import core, tasks, wardrobe  # noqa: E402

GARMENT, TIERS = "tshirt", ["xsmall"]
needs_ray = pytest.mark.skipif(importlib.util.find_spec("ray") is None,
                               reason="needs ray (PLEAT_EXTRAS=train,ray scripts/setup.sh)")


@pytest.fixture(scope="module")
def cluster():
    import ray
    from ray.cluster_utils import Cluster
    c = Cluster(initialize_head=True, head_node_args={"num_cpus": 1, "object_store_memory": 150 * 2 ** 20,
                                                      "include_dashboard": False})
    c.add_node(num_cpus=1, object_store_memory=150 * 2 ** 20)
    c.wait_for_nodes()
    yield c
    if ray.is_initialized():
        ray.shutdown()
    c.shutdown()


def _build(runner, out, cache):
    cfg = core.load_config("tiny")
    return wardrobe.build(cfg, [GARMENT], out, runner, TIERS, cache_dir=cache, progress=False)


def _networks(path):
    _, w = S.read_weights(path)
    return {k: np.asarray(v) for k, v in w.items() if k != "metadata_json"}


@needs_ray
def test_a_ray_cluster_builds_the_assets_of_the_serial_path(cluster, tmp_path):
    import ray
    serial = _build(tasks.Serial(), tmp_path / "serial", tmp_path / "cache_serial")
    with tasks.RayTasks(cluster.address) as runner:
        assert runner.workers == 2 and len([n for n in ray.nodes() if n["Alive"]]) == 2
        on_ray = _build(runner, tmp_path / "ray", tmp_path / "cache_ray")
    assert not ray.is_initialized()            # close() left the cluster as it found it: not connected

    names = [f"{GARMENT}.pleat"] + [f"{GARMENT}_{t}.pleat" for t in TIERS]
    for name in names:
        a, b = _networks(tmp_path / "serial" / name), _networks(tmp_path / "ray" / name)
        assert a.keys() == b.keys()
        for k in a:
            assert np.array_equal(a[k], b[k]), f"{name}: {k} differs between the serial path and Ray"
    # the simulations: every cache file of one run in the other, with the same frames
    files = sorted(p.name for p in (tmp_path / "cache_serial").glob("*.npz"))
    assert files and files == sorted(p.name for p in (tmp_path / "cache_ray").glob("*.npz"))
    for name in files:
        with np.load(tmp_path / "cache_serial" / name) as x, np.load(tmp_path / "cache_ray" / name) as y:
            assert np.array_equal(x["positions"], y["positions"])
    # the records agree on what was built
    for r in (serial[0], on_ray[0]):
        assert r["garment"] == GARMENT and [t["tier"] for t in r["tiers"]] == TIERS and r["segments"] == 3
    assert serial[0]["validation"] == on_ray[0]["validation"]


@needs_ray
def test_the_command_writes_its_report(cluster, tmp_path):
    """pleat-wardrobe --address joins the cluster, builds and reports per garment (no tiers asked)."""
    status = wardrobe.main(["--garments", GARMENT, "--out", str(tmp_path / "w"), "--tiers", "--address",
                            cluster.address, "--cache-dir", str(tmp_path / "cache"), "--quiet"])
    assert status == 0
    report = json.loads((tmp_path / "w" / "wardrobe.json").read_text())
    assert report["runner"] == "ray" and report["cpus"] == 2
    [g] = report["garments"]
    assert g["garment"] == GARMENT and "tiers" not in g and (tmp_path / "w" / f"{GARMENT}.pleat").is_file()
    assert g["verdict"].startswith("verdict: ")


def test_without_ray_the_command_says_how_to_get_it(monkeypatch, tmp_path, capsys):
    import builtins
    real = builtins.__import__

    def no_ray(name, *a, **k):
        if name == "ray":
            raise ImportError("no ray")
        return real(name, *a, **k)
    monkeypatch.setattr(builtins, "__import__", no_ray)
    status = wardrobe.main(["--garments", GARMENT, "--out", str(tmp_path / "w")])
    assert status == 1 and "PLEAT_EXTRAS=train,ray" in capsys.readouterr().err
    assert not (tmp_path / "w").exists()
