"""Command line: ``rvtool analyze DESIGN [--protocols ...] [--quick] [--out DIR] [--device ...]
[--backend ...] [--scheduler ADDRESS] [--quiet]`` (the protocols of :mod:`rvtool.analysis` on a design file or a shipped design),
``rvtool designs [--format-doc]``, ``rvtool new --topology T [--name NAME]`` (a commented
design template and its tolerance file; ``rvtool new --tolerances-for DESIGN``: the tolerance file of
a design file), ``rvtool list``, ``rvtool run [CASE] [--quick] [--out DIR]``, ``rvtool version``,
``rvtool sweep SPEC [--scheduler ADDRESS] [--out DIR] [--quiet]`` (a parameter study or the
tolerance Monte Carlo on a Dask cluster; SPEC format in :mod:`rvtool.variants.sweep`),
``rvtool validate [DESIGN] [--quick] [--samples N] [--workers W] [--out DIR]`` (a shipped design
against its catalogue, :mod:`rvtool.analysis.validate`).

Input errors (a design key out of range, an unknown protocol or topology, a missing file) print
one line ``rvtool: error: ...`` naming the key path and the valid range, exit with status 2
and write nothing.

The studies are the scripts in the repository's ``cases/`` folder (see
``rvtool.casekit`` for their convention). ``list`` reads each script's module
docstring with ``ast``, without importing it, so that a broken or slow case
cannot stop the listing; ``run`` executes one case's ``main()`` in this
process. The folder is ``cases/`` beside the package unless the environment
variable ``RVTOOL_CASES`` names another one.
"""
import argparse
import ast
import importlib.util
import json
import os
import sys
from pathlib import Path

DEFAULT_STUDY = ("rd40", "te,stiffness,lost_motion")
"""Design and protocols of the short reducer study run (quick) by a bare ``rvtool run``; it needs
no cases folder, so it works from a wheel."""

CASES_ENV = "RVTOOL_CASES"
"""Environment variable that overrides the location of the cases folder."""

EXIT_USAGE = 2
"""Exit status of a usage error (argparse's convention)."""

_CASE_MODULE_PREFIX = "rvtool_case_"


def cases_dir():
    """Folder holding the case scripts: ``$RVTOOL_CASES`` or ``<repository>/cases``."""
    override = os.environ.get(CASES_ENV)
    if override:
        return Path(override).expanduser().resolve()
    return Path(__file__).resolve().parents[1] / "cases"


def discover_cases(folder=None):
    """Case names in ``folder``, sorted: ``group/name`` for ``folder/group/name.py`` (one level of
    sub-folders, the groups of :func:`case_groups`) and ``name`` for a script directly in ``folder``.
    Files and folders starting with ``_`` or ``.`` are helpers, not cases."""
    folder = cases_dir() if folder is None else Path(folder)
    if not folder.is_dir():
        return []
    names = []
    for p in list(folder.glob("*.py")) + list(folder.glob("*/*.py")):
        rel = p.relative_to(folder)
        if p.is_file() and not any(part.startswith(("_", ".")) for part in rel.parts):
            names.append(rel.with_suffix("").as_posix())
    return sorted(names)


def case_groups(folder=None):
    """``{group: [case name, ...]}`` of :func:`discover_cases`, the group being the sub-folder
    (``""`` for scripts directly in the cases folder)."""
    groups = {}
    for name in discover_cases(folder):
        group, _, _ = name.rpartition("/")
        groups.setdefault(group, []).append(name)
    return groups


def resolve_case(name, folder=None):
    """The case name (``group/name``) of ``name``: a case name as listed, the bare file stem of a case
    in any group (if unique) or either with ``.py``. Raises ``LookupError`` naming the candidates."""
    folder = cases_dir() if folder is None else Path(folder)
    name = name.replace(os.sep, "/")
    name = name[:-3] if name.endswith(".py") else name
    name = name[len("cases/"):] if name.startswith("cases/") else name
    available = discover_cases(folder)
    if name in available:
        return name
    matches = [n for n in available if n.rpartition("/")[2] == name]
    if len(matches) == 1:
        return matches[0]
    if matches:
        raise LookupError(f"case {name!r} is ambiguous in {folder}: " + ", ".join(matches))
    import difflib
    stems = {n.rpartition("/")[2]: n for n in available}
    close = difflib.get_close_matches(name.rpartition("/")[2], list(stems), n=3)
    hint = f" (did you mean {', '.join(repr(stems[c]) for c in close)}?)" if close else ""
    raise LookupError(f"unknown case {name!r} in {folder}{hint}; available cases: "
                      + (", ".join(available) if available else "(none)"))


def case_path(name, folder=None):
    """Path of the script of case ``name`` (any form :func:`resolve_case` accepts)."""
    folder = cases_dir() if folder is None else Path(folder)
    return folder / (resolve_case(name, folder) + ".py")


def case_summary(path):
    """First line of the module docstring of the script at ``path``, read without importing it."""
    try:
        tree = ast.parse(Path(path).read_text(encoding="utf-8"), filename=str(path))
    except (OSError, SyntaxError, ValueError) as exc:  # listed, flagged, not fatal
        return f"(unreadable: {type(exc).__name__}: {exc})"
    doc = ast.get_docstring(tree)
    if not doc:
        return "(no docstring)"
    return doc.strip().splitlines()[0]


def _missing_folder_message(folder):
    return (f"cases folder not found: {folder} "
            f"(run from a source checkout, or set {CASES_ENV} to the folder holding the case scripts)")


def _cmd_list(args):
    folder = cases_dir()
    if not folder.is_dir():
        print(f"rvtool: error: {_missing_folder_message(folder)}", file=sys.stderr)
        return EXIT_USAGE
    groups = case_groups(folder)
    width = max((len(n.rpartition("/")[2]) for names in groups.values() for n in names), default=0)
    for group, names in groups.items():
        print(f"{group or '.'}/")
        for name in names:
            print(f"  {name.rpartition('/')[2]:<{width}}  {case_summary(folder / (name + '.py'))}")
    return 0


def load_case(path, name):
    """Import the case script at ``path`` as a fresh module named after the case."""
    spec = importlib.util.spec_from_file_location(_CASE_MODULE_PREFIX + name, path)
    module = importlib.util.module_from_spec(spec)
    # Registered before execution: dataclasses and pickling look modules up by name.
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    return module


def run_case(name, quick=False, out=None):
    """Run case ``name``'s ``main()`` in this process (``cases/<group>/<name>.py``; the bare name or
    ``group/name``); return the path of the results.json it wrote.

    ``out`` defaults to ``results/<name>`` (the bare name) in the current directory, as when
    the script is run directly. While the case runs, ``sys.argv`` and
    ``sys.path[0]`` look as they would for ``python cases/<group>/<name>.py``, so that the
    recorded command and imports of helper modules beside the case behave the same.
    """
    path = case_path(name)
    folder = path.parent
    name = path.stem
    out = os.path.join("results", name) if out is None else out
    case_argv = (["--quick"] if quick else []) + ["--out", str(out)]
    saved_argv, saved_path = sys.argv, list(sys.path)
    sys.argv = [str(path)] + case_argv
    sys.path.insert(0, str(folder))
    try:
        module = load_case(path, name)
        if not callable(getattr(module, "main", None)):
            raise AttributeError(f"case {name!r} ({path}) defines no main(argv) function")
        module.main(case_argv)
    finally:
        sys.argv = saved_argv
        sys.path[:] = saved_path
        sys.modules.pop(_CASE_MODULE_PREFIX + name, None)
    return Path(out).resolve() / "results.json"


def _cmd_run(args, parser):
    if args.case is None:
        design, protocols = DEFAULT_STUDY
        out = args.out or os.path.join("results", f"analyze_{design}")
        return _analyze(design, protocols, quick=True, out=out, device="cpu", quiet=False, tolerances=None, allowables=None)
    folder = cases_dir()
    if not folder.is_dir():
        parser.error(_missing_folder_message(folder))
    try:
        name = resolve_case(args.case, folder)
    except LookupError as exc:
        parser.error(str(exc.args[0]))
    if args.out is not None:
        from rvtool.errors import RvtoolInputError
        from rvtool.validation import check_out_dir
        try:
            check_out_dir(args.out, "--out")
        except RvtoolInputError as exc:
            return _input_error(exc)
    results = run_case(name, quick=args.quick, out=args.out)
    if not results.is_file():
        print(f"rvtool: error: case {name!r} finished but wrote no {results}", file=sys.stderr)
        return 1
    print(f"{name}: results written to {results}")
    try:        # the case's own verdict (every case writes "passed" from its criteria), in one line
        passed = json.loads(results.read_text()).get("passed")
    except (OSError, ValueError, AttributeError):
        passed = None
    if passed is not None:
        print(f"{name}: passed = {str(bool(passed)).lower()} (by its own criteria, in results.json)")
    return 0


def _input_error(exc):
    """One line on stderr and the usage exit status (nothing has been written)."""
    print(f"rvtool: error: {' '.join(str(exc).split())}", file=sys.stderr)
    return EXIT_USAGE


def _analyze(design, protocols, *, quick, out, device, quiet, tolerances, allowables=None, backend="auto",
             scheduler=None, bearing_model=None):
    from rvtool import progress
    from rvtool.analysis import analyze
    from rvtool.errors import RvtoolInputError
    try:
        # validated first: an input error writes nothing
        from rvtool.analysis import load, resolve_device, select
        select(protocols)
        resolve_device(device)
        from rvtool.analysis import check_bearing_model
        check_bearing_model(load(design)[0], bearing_model)
    except RvtoolInputError as exc:
        return _input_error(exc)
    if out is None:
        stem = os.path.splitext(os.path.basename(str(design)))[0]
        out = os.path.join("results", f"analyze_{stem}")
    with progress.reporting("quiet" if quiet else "auto"):
        try:
            res = analyze(design, protocols, quick=quick, out_dir=out, device=device, tolerances=tolerances,
                          allowables=allowables, backend=backend, scheduler=scheduler, bearing_model=bearing_model)
        except RvtoolInputError as exc:
            return _input_error(exc)
    for r in res.results:
        line = f"{r.name:<12} {r.status:<8} {r.wall_s:7.2f} s"
        if r.status == "ok":
            line += "  " + ", ".join(f"{f.name} = {f.value:.4g} {f.unit}" for f in r.figures[:3]
                                     if isinstance(f.value, (int, float)))
        else:
            line += f"  {r.reason}"
        print(line)
    for w in res.warnings:
        print(f"warning: {w}", file=sys.stderr)
    print(f"{res.design_name}: results.json and report.html written to {os.path.abspath(out)}")
    return 0 if res.ok else 1


def _cmd_analyze(args):
    return _analyze(args.design, args.protocols, quick=args.quick, out=args.out, device=args.device,
                    quiet=args.quiet, tolerances=args.tolerances, allowables=args.allowables, backend=args.backend,
                    scheduler=args.scheduler, bearing_model=args.bearing_model)


def _cmd_designs(args):
    from rvtool import designs
    from rvtool.assembly import topologies
    from rvtool.errors import RvtoolInputError
    if args.format_doc:
        from rvtool.designs.format import format_doc
        sys.stdout.write(format_doc())
        return 0
    names = designs.design_names()
    width = max((len(n) for n in names), default=0)
    for n in names:
        try:
            d = topologies.load(n)
            label = f"{topologies.topology_of(d)}: {d.name}"
        except RvtoolInputError as exc:  # a shipped design that does not load is shown, not hidden
            label = f"(does not load: {exc})"
        print(f"{n:<{width}}  {label}  ({designs.path(n)})")
    print("topologies: " + ", ".join(f"{t}" + ("" if topologies.available(t) is None else " (not available)")
                                      for t in topologies.TOPOLOGIES))
    return 0


def _new_tolerances(args):
    """``rvtool new --tolerances-for DESIGN``: the tolerance file of a design file of one's own, its grades
    computed from that design's sizes (after its pins or gears changed)."""
    from rvtool.assembly import topologies
    from rvtool.designs.tolerance_template import tolerance_path, tolerance_template
    from rvtool.errors import RvtoolInputError
    if args.topology is not None or args.name is not None:
        return _input_error("--tolerances-for writes the tolerance file of an existing design: it takes no "
                            "--topology or --name (the design file gives them)")
    src = args.tolerances_for
    try:
        design = topologies.design_from_table(topologies.read_table(src))
        text = tolerance_template(design, os.path.basename(src))
    except RvtoolInputError as exc:
        return _input_error(exc)
    path = args.out or tolerance_path(src)
    if os.path.exists(path):
        return _input_error(f"{path} exists; move it aside or choose another --out (nothing was overwritten)")
    with open(path, "w", encoding="utf-8") as fh:
        fh.write(text)
    print(f"tolerances of {src} written to {path}" + ("" if args.out else f"; rvtool analyze {src} reads it"))
    return 0


def _cmd_new(args):
    from rvtool.assembly import topologies
    from rvtool.errors import RvtoolInputError
    if args.tolerances_for is not None:
        return _new_tolerances(args)
    if args.topology is None:
        return _input_error("rvtool new needs --topology T (cycloid, rv2, rv3 or std-involute), or "
                            "--tolerances-for DESIGN.toml")
    name = "mine" if args.name is None else args.name
    if not name.strip() or os.sep in name or (os.altsep and os.altsep in name):
        # '' used to write mine.toml silently, 'a/b' ended in a FileNotFoundError traceback
        return _input_error(f"--name = {name!r}; valid: a non-empty design name without a path separator, "
                            "the file stem (--out DIR/FILE.toml writes elsewhere)")
    path = args.out or f"{name}.toml"
    folder = os.path.dirname(path)
    if folder and not os.path.isdir(folder):
        return _input_error(f"--out = {path!r}: the folder {folder!r} does not exist; valid: a file in an existing "
                            "folder")
    try:
        topologies.get(args.topology)
        import tomllib

        from rvtool.designs.format import template
        from rvtool.designs.tolerance_template import tolerance_path, tolerance_template
        text = template(args.topology, name)
        # the tolerance file of the design's Monte Carlo, from the template's own sizes (pins, gears)
        tol_path = tolerance_path(path)
        tol_text = tolerance_template(topologies.design_from_table(tomllib.loads(text)), os.path.basename(path))
    except RvtoolInputError as exc:
        return _input_error(exc)
    for p in (path, tol_path):
        if os.path.exists(p):
            return _input_error(f"{p} exists; choose another --name or --out (nothing was overwritten)")
    for p, t in ((path, text), (tol_path, tol_text)):
        with open(p, "w", encoding="utf-8") as fh:
            fh.write(t)
    print(f"{args.topology} design template written to {path}, its tolerances to {tol_path}; "
          f"check it with: rvtool analyze {path} --quick")
    return 0


def _cmd_version(args):
    from rvtool import casekit  # imported here: it loads numpy and matplotlib

    for package, version in casekit.versions().items():
        print(f"{package}: {version if version is not None else 'not installed'}")
    return 0


def _cmd_sweep(args, parser):
    from rvtool.errors import RvtoolInputError
    from rvtool.variants.sweep import main_sweep  # imported here: it loads Exudyn and Dask

    if not os.path.isfile(args.spec):
        parser.error(f"sweep spec not found: {args.spec}")
    try:
        if args.out is not None:
            from rvtool.validation import check_out_dir
            check_out_dir(args.out, "--out")
        main_sweep(args.spec, scheduler=args.scheduler, out_dir=args.out, quiet=args.quiet)
    except RvtoolInputError as exc:
        print(f"rvtool: error: {exc}", file=sys.stderr)
        return EXIT_USAGE
    return 0


def _cmd_validate(args):
    from rvtool.analysis.validate import table_text, validate, validated_designs
    from rvtool.analysis.validate_te import COMMITTED_RESULTS
    from rvtool.errors import RvtoolInputError
    names = [args.design] if args.design else validated_designs()
    if args.samples is not None and args.samples < 2:
        return _input_error(f"--samples = {args.samples} is outside the valid range [2, inf)")
    if args.workers < 1:
        return _input_error(f"--workers = {args.workers} is outside the valid range [1, inf)")
    if args.tornado_keys is not None and args.tornado_keys < 0:     # a negative K dropped keys from the end
        return _input_error(f"--tornado-keys = {args.tornado_keys} is outside the valid range [0, inf) "
                            "(0: no tornado)")
    log = (lambda *a, **k: None) if args.quiet else (lambda *a, **k: print(*a, file=sys.stderr, **k))
    if args.out is not None:
        from rvtool.validation import check_out_dir
        try:
            check_out_dir(args.out, "--out")
        except RvtoolInputError as exc:
            return _input_error(exc)
    for name in names:
        out_dir = os.path.join(args.out, name) if args.out else os.path.join("results", f"validate_{name}")
        try:
            out = validate(name, quick=args.quick, out_dir=out_dir, samples=args.samples, workers=args.workers,
                           tornado_keys=args.tornado_keys, log=log,
                           te_reuse=None if args.quick else [COMMITTED_RESULTS])   # where its digest matches
        except RvtoolInputError as exc:
            return _input_error(exc)
        print(table_text(out))
        print(f"written: {out_dir}/results.json, report.html")
    return 0


def build_parser():
    """The ``rvtool`` argument parser with its subcommands."""
    from rvtool import __version__

    parser = argparse.ArgumentParser(
        prog="rvtool",
        description=f"rvtool {__version__}: precision gear reducer studies on Exudyn with Warp contact kernels.",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    an = sub.add_parser("analyze", help="analyse a design: protocols, results.json, plots, report.html",
                        description="Run protocols on DESIGN (a design file or the name of a shipped design, "
                                    "see 'rvtool designs') and write results.json, PNG plots and a self-contained "
                                    "report.html.")
    an.add_argument("design", metavar="DESIGN", help="design file (TOML) or shipped design name (e.g. rd40)")
    an.add_argument("--protocols", default=None, metavar="LIST",
                    help="comma-separated protocols (default: all): te, stiffness, lost_motion, hysteresis, "
                         "vibration, pressure, monte_carlo")
    an.add_argument("--quick", action="store_true", help="short forms of the protocols (seconds each)")
    an.add_argument("--out", default=None, metavar="DIR", help="output directory (default: results/analyze_DESIGN)")
    an.add_argument("--device", default="cpu", metavar="DEVICE", help="auto, cpu (default) or cuda[:N]")
    an.add_argument("--backend", default="auto", choices=("auto", "exudyn", "replica", "device", "fused"),
                    help="solver backend: auto (default: the fastest that supports the model, the choice and "
                         "the reasons recorded in results.json), exudyn (every model), replica, device or fused "
                         "(the device family: device Newton for equilibria and torque paths; driven runs, e.g. "
                         "--protocols vibration, on the fused stepper for cycloids with lumped bearings, else "
                         "on the row stepper: RV and other models with device rows)")
    an.add_argument("--bearing-model", default=None, metavar="MODEL",
                    help="cycloid and small-tooth-difference designs: lumped (default: one circle contact per "
                         "bearing) or rolling (rolling elements; needed by spatial bodies and influence roller "
                         "slices, slower)")
    an.add_argument("--scheduler", default=None, metavar="ADDRESS",
                    help="Dask scheduler of the Monte Carlo's CPU pool (default: a LocalCluster started for it)")
    an.add_argument("--quiet", action="store_true", help="no progress output")
    an.add_argument("--tolerances", default=None, metavar="FILE",
                    help="tolerance file of the Monte Carlo (default: <design>_tolerances.toml beside the design file, "
                         "as 'rvtool new' writes it, or a shipped design's)")
    an.add_argument("--allowables", default=None, metavar="FILE",
                    help="design-review allowables the report's summary checks (default: <design>_allowables.toml "
                         "beside the design file, or a shipped design's)")
    ds = sub.add_parser("designs", help="list the shipped designs and topologies",
                        description="List the shipped reference designs; --format-doc prints the design file "
                                    "format (every section and key, units, ranges) generated from the specs.")
    ds.add_argument("--format-doc", action="store_true", help="print the design file format documentation (Markdown)")
    nw = sub.add_parser("new", help="write a commented design template and its tolerance file",
                        description="Write NAME.toml: a design template of the topology with units and valid "
                                    "ranges in comments, generated from the component specs; and NAME_tolerances.toml "
                                    "beside it: the manufacturing tolerances of its Monte Carlo (each grade's source "
                                    "or 'assumed' in its comment), which 'rvtool analyze NAME.toml' reads.")
    nw.add_argument("--topology", default=None, metavar="T", help="cycloid, rv2, rv3 or std-involute")
    nw.add_argument("--name", default=None, help="design name and file stem (default: mine)")
    nw.add_argument("--out", default=None, metavar="FILE",
                    help="output file (default: NAME.toml; with --tolerances-for: DESIGN_tolerances.toml)")
    nw.add_argument("--tolerances-for", default=None, metavar="DESIGN",
                    help="write only the tolerance file of the design file DESIGN, its grades from that design's "
                         "sizes (after its pins or gears changed)")
    sub.add_parser("list", help="list the cases by folder (name and first docstring line)",
                   description="List the case scripts, grouped by their folder (cycloid, rv, std, "
                               "verification, benchmarks, hard, studies), with the first line of each one's docstring.")
    run = sub.add_parser("run", help="run a case in this process (no CASE: a short reducer study)",
                         description=f"Run cases/GROUP/CASE.py's main(). Without CASE, runs the short reducer study "
                                     f"'rvtool analyze {DEFAULT_STUDY[0]} --quick --protocols {DEFAULT_STUDY[1]}'.")
    run.add_argument("case", nargs="?", default=None, metavar="CASE",
                     help="case name as printed by 'rvtool list', bare or as GROUP/NAME (default: the short reducer study)")
    run.add_argument("--quick", action="store_true", help="fast, reduced version of the study")
    run.add_argument("--out", default=None, metavar="DIR", help="output directory (default: results/CASE)")
    sub.add_parser("version", help="print the versions of rvtool and the packages results depend on",
                   description="Print the versions recorded in every results.json provenance.")
    sweep = sub.add_parser("sweep", help="run a parameter study or the tolerance Monte Carlo on Dask",
                           description="Run the sweep described by the TOML file SPEC (format: rvtool.variants.sweep) on a "
                                       "Dask LocalCluster or an existing scheduler; writes results.csv and results.json.")
    sweep.add_argument("spec", metavar="SPEC", help="sweep specification (TOML)")
    sweep.add_argument("--scheduler", default=None, metavar="ADDRESS",
                       help="address of an existing Dask scheduler (default: start a LocalCluster)")
    sweep.add_argument("--out", default=None, metavar="DIR", help="output directory (default: the spec's output_dir)")
    sweep.add_argument("--quiet", action="store_true", help="no progress bar")
    va = sub.add_parser("validate", help="a shipped design against its catalogue (predicted vs catalogue table)",
                        description="Compare DESIGN (default: every shipped design with a <design>_catalogue.toml) "
                                    "with its catalogue by the catalogue's own definitions: rigidity, lost motion, "
                                    "hysteresis loss, rated life, with an uncertainty band over the assumed ranges; "
                                    "writes results.json, PNGs and report.html.")
    va.add_argument("design", nargs="?", default=None, metavar="DESIGN", help="shipped design name (e.g. rv40e)")
    va.add_argument("--quick", action="store_true", help="4 Latin-hypercube samples instead of 64, a 1-key tornado, coarse central loop")
    va.add_argument("--samples", type=int, default=None, metavar="N", help="Latin-hypercube samples (>= 2)")
    va.add_argument("--workers", type=int, default=1, metavar="W", help="processes for the samples (default 1)")
    va.add_argument("--tornado-keys", type=int, default=None, metavar="K",
                    help="one-at-a-time tornado over the K most important assumed keys (LHS screening; default all)")
    va.add_argument("--out", default=None, metavar="DIR", help="output directory (default: results/validate_DESIGN)")
    va.add_argument("--quiet", action="store_true", help="no progress output")
    return parser


def main(argv=None):
    """Entry point of the ``rvtool`` console script; returns the exit status. A reader that closes
    the output early (``rvtool list | head``) ends the command quietly, as other command-line tools
    do (it was a ``BrokenPipeError`` traceback)."""
    try:
        return _main(argv)
    except BrokenPipeError:
        # Python's documented recipe (library/signal, "Note on SIGPIPE"): send the rest to /dev/null so
        # that the interpreter's final flush of stdout does not raise again, and exit with 1
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        return 1


def _main(argv):
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.command == "analyze":
        return _cmd_analyze(args)
    if args.command == "designs":
        return _cmd_designs(args)
    if args.command == "new":
        return _cmd_new(args)
    if args.command == "list":
        return _cmd_list(args)
    if args.command == "run":
        return _cmd_run(args, parser)
    if args.command == "version":
        return _cmd_version(args)
    if args.command == "sweep":
        return _cmd_sweep(args, parser)
    if args.command == "validate":
        return _cmd_validate(args)
    parser.print_help(sys.stderr)
    return EXIT_USAGE


if __name__ == "__main__":
    sys.exit(main())
