"""The add-on as a zip for Blender's "Install from Disk": one folder, pleat_blender/, with __init__.py (bl_info)
and blender_manifest.toml, so both the legacy add-on installer and the extension installer take it.

    python -m pleat_blender.package [--out dist/pleat_blender.zip]
"""
import argparse
import zipfile
from pathlib import Path

HERE = Path(__file__).resolve().parent


def build_zip(out):
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    files = sorted(p for p in HERE.iterdir() if p.suffix in (".py", ".toml") and p.is_file())
    with zipfile.ZipFile(out, "w", zipfile.ZIP_DEFLATED) as z:
        for p in files:
            z.write(p, f"pleat_blender/{p.name}")
    return out


def main(argv=None):
    p = argparse.ArgumentParser(prog="python -m pleat_blender.package", description=__doc__.splitlines()[0])
    p.add_argument("--out", default="dist/pleat_blender.zip")
    args = p.parse_args(argv)
    print(f"pleat_blender: wrote {build_zip(args.out)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
