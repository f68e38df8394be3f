"""`pleat-wardrobe`: every garment of a list built by the simulator-supervised recipe, with its cheaper tiers, on Ray
(docs/training-speed.md, "Many garments, many machines").

    pleat-wardrobe --garments tshirt dress pants tank_top long_sleeve --preset default --out out/wardrobe
    pleat-wardrobe ... --address auto          # join the running Ray cluster instead of starting one here
    pleat-wardrobe ... --serial                # one job after another in this process: the reference

Each garment runs `pleat-train simsup` (its simulated segments, the validation clips, the fits, the students) and
`pleat-train simsup-tiers` (one fit per tier). Their segments and fits are Ray tasks of one CPU each
(pleat.train.tasks), so the garments' jobs share the cluster: while one garment waits for its last fit, the next
garment's segments fill the free CPUs. What is not a task stays in this process, one thread per garment: reading
and writing the simulation cache, un-skinning the simulated frames, the ensemble means, the contact-aware fine-tune
and packing; so the run folders, the cache and the assets are all on this machine.

Writes OUT/<garment>.pleat, OUT/<garment>_<tier>.pleat, the run folders OUT/runs/<garment>/ and OUT/wardrobe.json
(per garment: wall time, validation verdict, tiers; the runner, the CPUs, the machine). With the same settings and
no time budget (--max-minutes), --serial and Ray give the same networks: every job sets its own seed and runs torch
and numpy's BLAS on one thread wherever it runs (pleat.train.tasks.one_cpu) (tests/python/test_wardrobe.py checks it on a local two-node cluster). With a budget
they differ, since a budget decides how many segments are simulated and how long each fit runs.
"""
import argparse
import json
import shutil
import sys
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

from pleat.cli import InputError, add_quiet, command, progress_note


def build_parser():
    p = argparse.ArgumentParser(prog="pleat-wardrobe", description=__doc__.split("\n\n")[0],
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--garments", nargs="+", required=True,
                   help="garment names or npz files (pleat-garment), built in this order")
    p.add_argument("--out", required=True, help="output folder: the assets, OUT/runs/<garment>/, wardrobe.json")
    p.add_argument("--preset", default="tiny", help="configs/<preset>.json (tiny, default)")
    p.add_argument("--config", default=None, help="a config file instead of the preset")
    p.add_argument("--set", action="append", default=[], metavar="KEY=JSON",
                   help="override a setting for every garment (repeatable; pleat-train config lists the keys)")
    p.add_argument("--tiers", nargs="*", default=["small", "xsmall"],
                   help="cheaper tiers distilled from each garment's model (pleat.eval.tiers; none: --tiers)")
    p.add_argument("--max-minutes", type=float, default=None,
                   help="wall-clock budget of each garment's simsup run (default none: the preset's plan)")
    where = p.add_mutually_exclusive_group()
    where.add_argument("--address", default=None,
                       help="join this running Ray cluster (\"auto\", host:port, ray://host:10001) instead of "
                            "starting a local Ray")
    where.add_argument("--serial", action="store_true",
                       help="no Ray: every job one after another in this process (the reference a Ray build "
                            "matches)")
    p.add_argument("--cpus", type=int, default=None, help="CPUs of the local Ray (default all of this machine)")
    p.add_argument("--cache-dir", default=None, help="the simulation cache (default out/cache/sim)")
    add_quiet(p)
    return p


def build_garment(cfg, garment, out, runner, tiers, max_minutes=None, cache_dir=None, progress=True):
    """One garment: simsup into OUT/runs/<name>/, its tiers, the assets copied to OUT. Returns its record."""
    from pleat.train import simsup
    t0 = time.time()
    name = Path(str(garment)).stem
    run_dir = Path(out) / "runs" / name
    data = run_dir / "data.npz"
    asset, summary = simsup.train(cfg, garment, run_dir, workers=runner.workers, max_minutes=max_minutes,
                                  progress=progress, cache_dir=cache_dir, export=data, runner=runner)
    summary = json.loads((run_dir / "simsup_summary.json").read_text())     # after the contact fine-tune, if any
    record = {"garment": name, "asset": str(Path(out) / Path(asset).name), "segments": summary["segments"],
              "frames": summary["frames"], "simulation_cpu_h": summary["simulation_cpu_h"],
              "validation": summary["validation"], "verdict": simsup.verdict(summary["validation"])}
    shutil.copyfile(asset, record["asset"])
    if tiers:
        reports = simsup.distill_tiers(run_dir, str(data), tiers, run_dir / "tiers", progress=progress,
                                       runner=runner)
        record["tiers"] = []
        for tier_name, rep in zip(tiers, reports):
            target = Path(out) / Path(rep["asset"]).name
            shutil.copyfile(rep["asset"], target)
            record["tiers"].append({"tier": tier_name, "asset": str(target), "fit_wall_s": rep.get("fit_wall_s"),
                                    "validation": rep.get("simulator_validation")})
    record["wall_s"] = time.time() - t0
    return record


def build(cfg, garments, out, runner, tiers, max_minutes=None, cache_dir=None, progress=True):
    """Every garment: one after another with a Serial runner, side by side (a thread each) otherwise."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    jobs = [lambda g=g: build_garment(cfg, g, out, runner, tiers, max_minutes, cache_dir, progress)
            for g in garments]
    if runner.name == "serial":
        return [job() for job in jobs]
    with ThreadPoolExecutor(max_workers=len(jobs)) as pool:
        return [f.result() for f in [pool.submit(job) for job in jobs]]


@command("pleat-wardrobe", build_parser)
def main(args):
    try:
        import torch  # noqa: F401
    except ImportError:
        print("pleat-wardrobe needs PyTorch: PLEAT_EXTRAS=train,ray scripts/setup.sh", file=sys.stderr)
        return 2
    from pleat.train import core, settings, tasks
    try:
        overrides = settings.parse_set(args.set)
    except settings.SettingError as exc:
        raise InputError(None, f"--set: {exc}") from None
    cfg = core.load_config(args.preset, args.config, overrides)
    t0 = time.time()
    runner = tasks.Serial() if args.serial else tasks.RayTasks(args.address, args.cpus)
    try:
        progress_note(args, f"pleat-wardrobe: {len(args.garments)} garments on {runner.name} "
                            f"({runner.workers} CPUs)")
        records = build(cfg, args.garments, args.out, runner, args.tiers, args.max_minutes, args.cache_dir,
                        not args.quiet)
    finally:
        if runner.name == "ray":
            runner.close()
    report = {"runner": runner.name, "cpus": runner.workers, "address": args.address, "preset": args.preset,
              "overrides": overrides, "tiers": args.tiers, "wall_s": time.time() - t0, "hardware": core.hardware(),
              "garments": records}
    from pleat import fileio
    fileio.write_text(Path(args.out) / "wardrobe.json", json.dumps(report, indent=1, default=str))
    for r in records:
        print(f"{r['garment']}: {r['verdict']} ({r['wall_s']:.0f} s)")
    print(f"pleat-wardrobe: {len(records)} garments in {report['wall_s']:.0f} s on {runner.name} "
          f"({runner.workers} CPUs) -> {args.out}")
    return 0
