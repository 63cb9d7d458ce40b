"""Commit a case run's results.json for the docs: copy it to
``docs/case_results/<folder>/<case>/results.json`` and write ``source.json`` beside it (commit,
host, date, mode, command), which the docs build prints with every table and figure it draws
from the file.

    python docs/_ext/collect_results.py RUN_DIR CASE FOLDER [--mode --quick] [--note TEXT]

RUN_DIR is the case's output folder (``--out`` of the run). Only results.json is copied (no
PNGs, no details.json): the docs draw their own figures from the data.
"""
import argparse
import datetime
import json
import platform
import shutil
import subprocess
from pathlib import Path

DOCS = Path(__file__).resolve().parents[1]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("run_dir")
    ap.add_argument("case")
    ap.add_argument("folder", help="docs/case_results folder: verification, benchmarks, cycloid, rv, std, analyze, ...")
    ap.add_argument("--mode", default="--quick", help="how the case was run (default --quick)")
    ap.add_argument("--commit", default=None, help="commit the run was made at (default: HEAD of this checkout)")
    ap.add_argument("--host", default=None, help="host description (default: this machine's)")
    ap.add_argument("--note", default="")
    args = ap.parse_args(argv)
    src = Path(args.run_dir) / "results.json"
    data = json.loads(src.read_text())          # fails loudly on a broken file
    dest = DOCS / "case_results" / args.folder / args.case
    dest.mkdir(parents=True, exist_ok=True)
    shutil.copyfile(src, dest / "results.json")
    commit = args.commit or subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True,
                                           cwd=DOCS).stdout.strip()
    dirty = subprocess.run(["git", "status", "--porcelain", "--", "rvtool", "cases", "warp_contacts",
                            "exudyn_user_elements"], capture_output=True, text=True, cwd=DOCS.parent).stdout.strip()
    mtime = datetime.datetime.fromtimestamp(src.stat().st_mtime, datetime.timezone.utc)
    host = args.host or f"{platform.node() or 'unnamed'} ({platform.machine()}, {platform.system()})"
    source = {"commit": commit + ("+local changes" if dirty and not args.commit else ""), "host": host,
              "date": mtime.strftime("%Y-%m-%d %H:%M UTC"), "mode": args.mode,
              "command": (args.mode if args.mode.startswith("rvtool ")
                          else f"python cases/<folder>/{args.case}.py {args.mode} --out DIR"),
              "note": args.note}
    (dest / "source.json").write_text(json.dumps(source, indent=1) + "\n")
    print(f"{dest}: {len(json.dumps(data))} bytes, verdict keys {'passed' in json.dumps(data)}")


if __name__ == "__main__":
    main()
