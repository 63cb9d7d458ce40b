"""The all-members-on rigidity row of `rvtool validate` (issue 30; rvtool.analysis.validate_members): the members
files (switches, ranges at their middles, fixed at a recorded commit), the derived pillar holes, and the four-solve
b/a against the loop's b/a of the catalogue protocol."""
import re
import subprocess
import tomllib
from pathlib import Path

import numpy as np
import pytest

import rvtool
from rvtool import designs
from rvtool.analysis import validate_members as VM
from rvtool.assembly.topologies import design_from_table, read_table
from rvtool.errors import RvtoolInputError

MEMBERS = sorted(n[: -len("_members")] for n in designs.names() if n.endswith("_members"))


def _git(*args):
    try:
        out = subprocess.run(["git", *args], cwd=Path(designs.path("rv80e")).parent, capture_output=True, text=True,
                             timeout=30)
    except (OSError, subprocess.SubprocessError):
        return None
    return out.stdout if out.returncode == 0 else None


def test_validation_designs_have_members_files():
    assert {"rv40e", "rv80e"} <= set(MEMBERS)


@pytest.mark.parametrize("name", MEMBERS)
def test_members_table_at_the_middles_builds_a_valid_design(name):
    """Every switch on, every input at the middle of its range, the pillar holes around the carrier's pillars
    (radius = pillar radius + eccentricity + running gap): a design the loader accepts."""
    switches, derived, assumed, _ = VM.load_members(f"{name}_members")
    mid = {a.key: a.middle for a in assumed.inputs}
    t = VM.members_table(read_table(designs.path(name)), switches, derived, mid)
    d = design_from_table(t)
    assert d.wheels.body == "ported" and d.pins.groove == "conformal" and d.carrier.body == "ported"
    assert d.cranks.shaft.elastic and d.cranks.shaft.torsion == "elastic" and d.housing.model == "ports"
    assert d.pins.groove_clearance == pytest.approx(mid["pins.groove_clearance"], rel=0, abs=0)
    hs = d.wheels.structure.pillar_holes
    cs = t["carrier"]["structure"]
    assert hs.radius == pytest.approx(cs["pillar_radius"] + d.wheels.eccentricity + mid["members.pillar_running_gap"],
                                      rel=1e-12)
    assert hs.circle_radius == cs["pillar_circle_radius"] and hs.count == 3
    for a in assumed.inputs:
        assert a.source.strip() and ("not a citation" in a.source or "[" in a.source), a.key


@pytest.mark.parametrize("name", MEMBERS)
def test_members_commit_holds_todays_inputs(name):
    """Issue 28 Deliver 4: the members file records the commit that fixed its ranges before the first
    all-members-on comparison; that commit's switches and ranges equal today's."""
    now = tomllib.loads(Path(designs.path(f"{name}_members")).read_text())
    sha = now.get("assumptions_commit")
    if sha is None:
        pytest.skip("assumptions_commit not yet recorded")
    assert re.fullmatch(r"[0-9a-f]{7,40}", sha)
    root = _git("rev-parse", "--show-toplevel")
    if root is None or _git("cat-file", "-e", f"{sha}^{{commit}}") is None:
        pytest.skip("no git history here (installed copy)")
    rel = Path(designs.path(f"{name}_members")).resolve().relative_to(Path(root.strip()).resolve())
    then = tomllib.loads(_git("show", f"{sha}:{rel}"))
    assert then["members"] == now["members"]
    assert then["assumed"] == now["assumed"]


def test_unknown_members_key_and_friction_refused():
    switches, derived, assumed, _ = VM.load_members("rv40e_members")
    t = read_table(designs.path("rv40e"))
    with pytest.raises(RvtoolInputError, match=r"members\.bogus"):
        VM.members_table(t, switches, derived, {"members.bogus": 1.0})
    d = rvtool.load_design(designs.path("rv40e")).replace(pin_contact={"mu": 0.05})
    with pytest.raises(RvtoolInputError, match=r"pin_contact\.mu"):
        VM.check_frictionless(d)


def test_four_solve_rigidity_equals_the_loops(tmp_path):
    """On rv40e as its file has it (frictionless), b/a from +-T_1, +-T_2 alone equals the catalogue loop's b/a
    (rvtool.analysis.validate's central loop at 50 % steps) within 1e-6 relative: the loading branches of a
    frictionless model are its static curve (the Newton tolerance moves an angle by ~1e-7 arcmin of ~0.5)."""
    from rvtool.analysis.validate import QUICK_STEP, rigidity_points
    from rvtool.designs.catalogue import load_catalogue
    from rvtool.protocols import catalogue as C
    from rvtool.units import RAD_PER_ARCMIN
    cat = load_catalogue(designs.catalogue_of("rv40e"))
    d = rvtool.load_design(designs.path("rv40e"))
    pts, _ = rigidity_points(cat)
    seq = C.catalogue_sequence(cat.test.rated_torque, rigidity_points=pts,
                               lost_motion_fraction=cat.test.lost_motion_torque_fraction, step=QUICK_STEP)
    r = C.catalogue_loop(C.ContinuationPath(rvtool.build(d)), seq, rigidity_points=pts,
                         lost_motion_fraction=cat.test.lost_motion_torque_fraction)
    loop = r["metrics"].rigidity.value * RAD_PER_ARCMIN
    four = VM.rigidity_ba(d, cat)
    assert four["value"] == pytest.approx(loop, rel=1e-6)
    assert np.all(np.isfinite(four["angles_arcmin"]))


def _draws(name, n):
    from scipy.stats import qmc
    from rvtool.designs.catalogue import load_assumed
    table = read_table(designs.path(name))
    switches, derived, members, _ = VM.load_members(f"{name}_members")
    assumed = designs.assumed_of(name)
    base = list(load_assumed(assumed).inputs) if assumed else []
    U = qmc.LatinHypercube(d=len(base) + len(members.inputs), seed=0).random(n)     # members_rigidity's draws
    return table, switches, derived, base, members.inputs, U


@pytest.mark.parametrize("n", [8, 64])
def test_rv80e_band_draws_are_valid_assemblies(n):
    """Every Latin-hypercube draw of rv80e's all-members-on band (seed 0; 8: the short band whose draws 2 and 4
    failed with a main-bearing row outside the carrier plates; 64: the full band, 10 such draws and 21 with a
    wheel face inside a plate under the independent sampler) is an assembly that exists: the carrier accepts
    the rows, the wheels end before the plates, the crank's stations are its rows; every drawn row spacing lies in its
    cited range."""
    from rvtool.assembly.carrier import check_carrier
    table, switches, derived, base, members, U = _draws("rv80e", n)
    ranges = {a.key: a for a in base if a.key in VM.LAYOUT_KEYS}
    assert set(ranges) == set(VM.LAYOUT_KEYS)
    moved = 0
    for u in U:
        t = VM.sample_table(table, base, members, u, switches, derived, VM.QUICK_NUMERICS)
        check_carrier(design_from_table(t))                # raises for a row outside the plates
        cs = t["carrier"]["structure"]
        w = t["wheels"]
        assert max(abs(z) for z in w["midplanes"]) + w["width"] / 2 <= cs["inner_face_position"]
        for k, a in ranges.items():
            v = t[k.split(".")[0]][k.split(".")[1]]
            assert a.low <= v <= a.high, (k, v)
            j = base.index(a)
            moved += v != a.at(u[j])
        half = t["crank_bearing"]["row_spacing"] / 2
        assert t["cranks"]["shaft"]["supports"] == [-half, half]     # the crank's stations are its tapered rows
    assert moved > 0          # the placement acts on this design's draws (else the test would prove nothing)


def test_rv40e_band_draws_unchanged():
    """rv40e's 64 committed draws (its members' ranges only; rows fixed inside the plates, wheels fixed) are
    bit-identical to the independent sampler's."""
    table, switches, derived, base, members, U = _draws("rv40e", 64)
    for u in U:
        vals = {a.key: a.at(uj) for a, uj in zip(members, u[len(base):])}
        assert VM.sample_table(table, base, members, u, switches, derived) == \
            VM.members_table(table, switches, derived, vals)


def test_row_placement_fraction_of_feasible_part():
    """A drawn row spacing is the fraction u of the part of its cited range the plates leave (no clamp: u = 0
    and 1 reach the ends of that part, u = 1/2 its middle); inside, exactly the range's own value; no
    feasible part: refused naming the key."""
    from rvtool.designs.catalogue import AssumedInput
    a = AssumedInput(key="main_bearing.row_spacing", low=0.05, high=0.07, unit="m", source="test")
    assert VM.placed_value(a, 0.3, (0.036, 0.08)) == a.at(0.3)
    assert VM.placed_value(a, 0.0, (0.036, 0.062)) == 0.05
    assert VM.placed_value(a, 1.0, (0.036, 0.062)) == pytest.approx(0.062, rel=1e-15)
    assert VM.placed_value(a, 0.5, (0.036, 0.062)) == pytest.approx(0.056, rel=1e-15)
    with pytest.raises(RvtoolInputError, match=r"main_bearing\.row_spacing"):
        VM.placed_value(a, 0.5, (0.036, 0.048))


def test_members_tornado_screens_and_places_valid_points(monkeypatch):
    """The band's tornado (no FE: b/a replaced by a known function of two inputs) picks the input whose
    fraction drives b/a, sets it to both ends of its range -- a row spacing to the ends of its FEASIBLE part
    (rv80e's main rows at the middle plates: 50 mm and 69 mm, not the cited 70 mm, which would put a row outside
    the plates) -- and leaves the crank supports (derived) out of the screening."""
    from rvtool.assembly.carrier import check_carrier
    from rvtool.designs.catalogue import load_assumed, load_catalogue
    seen = []

    def fake(design, catalogue):
        check_carrier(design)
        seen.append(design)
        return {"value": 1e4 * design.main_bearing.row_spacing + 1e3 * design.carrier.structure.flange_thickness}
    monkeypatch.setattr(VM, "rigidity_ba", fake)
    base = load_assumed(designs.assumed_of("rv80e"))
    b, m, _, _ = VM.band_inputs("rv80e", base)
    keys = [a.key for a in b + m]
    U = VM.band_fractions(len(keys), 64, 0)
    values = [1e4 * (0.05 + 0.02 * u[keys.index("main_bearing.row_spacing")]) for u in U]
    values[5] = None                                             # a failed sample is left out of the screening
    r = VM.members_tornado("rv80e", read_table(designs.path("rv80e")), load_catalogue(designs.catalogue_of("rv80e")),
                           base, values, keys=2, log=lambda *a: None)
    assert len(seen) == 5 and list(r["tornado"])[0] == "main_bearing.row_spacing"
    assert VM.SUPPORTS_KEY not in r["screening_spearman_rho"] and len(r["screening_spearman_rho"]) == len(keys) - 1
    t = r["tornado"]["main_bearing.row_spacing"]
    assert t["low"] == 0.05 and t["high"] == pytest.approx(2 * (0.018 + 0.0165), rel=1e-12)
    assert t["at_low"] < r["baseline"] < t["at_high"] and not t["errors"]

    # the same points in two processes (forked: the stand-in b/a travels with them) give the same tornado
    r2 = VM.members_tornado("rv80e", read_table(designs.path("rv80e")), load_catalogue(designs.catalogue_of("rv80e")),
                            base, values, keys=2, log=lambda *a: None, workers=2)
    assert r2["baseline"] == r["baseline"] and r2["tornado"] == r["tornado"]

def test_sampled_tornado_recovers_a_linear_response():
    """The tornado estimated from the band's samples: for b/a exactly linear in two inputs' fractions (swings
    30 and -20 N m/arcmin about 200) the fit returns those swings and ends (1e-9), R^2 = 1, and ranks them first."""
    from rvtool.designs.catalogue import load_assumed
    base = load_assumed(designs.assumed_of("rv80e"))
    b, m, _, _ = VM.band_inputs("rv80e", base)
    keys = [a.key for a in b + m]
    U = VM.band_fractions(len(keys), 64, 0)
    i, j = keys.index("carrier.structure.pillar_radius"), keys.index("wheels.width")
    values = [200.0 + 30.0 * (u[i] - 0.5) - 20.0 * (u[j] - 0.5) for u in U]
    values[7] = None
    r = VM.sampled_tornado("rv80e", base, values, keys=8)
    assert list(r["tornado"])[:2] == ["carrier.structure.pillar_radius", "wheels.width"]
    t = r["tornado"]["carrier.structure.pillar_radius"]
    assert t["swing"] == pytest.approx(30.0, abs=1e-9) and t["at_high"] == pytest.approx(215.0, abs=1e-9)
    assert r["tornado"]["wheels.width"]["at_low"] == pytest.approx(210.0, abs=1e-9)
    assert r["baseline"] == pytest.approx(200.0, abs=1e-9) and r["r_squared"] == pytest.approx(1.0, abs=1e-12)
    assert r["samples_used"] == 63 and r["tornado_keys"] == 8


def _stand_in_rigidity(monkeypatch):
    """(calls, rv40e catalogue, rv40e table) with ``rigidity_ba`` replaced by a stand-in b/a (1e4 x the drawn
    pillar radius, no FE) that counts its calls: the checkpoint tests count solves, not stiffness."""
    from rvtool.designs.catalogue import load_catalogue
    calls = []

    def fake(design, catalogue):
        calls.append(1)
        return {"value": 1e4 * design.carrier.structure.pillar_radius, "networks": {}, "solver": {}}
    monkeypatch.setattr(VM, "rigidity_ba", fake)
    return calls, load_catalogue(designs.catalogue_of("rv40e")), read_table(designs.path("rv40e"))


def test_band_checkpoint_resumes_and_deadline_shortens(monkeypatch, tmp_path):
    """members_rigidity with a checkpoint: a second call with the same draws solves nothing and returns the same
    band; a deadline already past starts no sample (the caller gets a clear error, not an empty band)."""
    calls, cat, table = _stand_in_rigidity(monkeypatch)
    ck = str(tmp_path / "ck.json")
    a = VM.members_rigidity("rv40e", table, cat, samples=3, checkpoint=ck, checkpoint_out=ck, log=lambda *x: None)
    assert len(calls) == 4 and a["samples_done"] == 3
    b = VM.members_rigidity("rv40e", table, cat, samples=3, checkpoint=ck, checkpoint_out=ck, log=lambda *x: None)
    assert len(calls) == 4 and b["sample_values"] == a["sample_values"] and b["band"] == a["band"]
    with pytest.raises(RvtoolInputError, match="deadline"):
        VM.members_rigidity("rv40e", table, cat, samples=3, deadline=0.0, log=lambda *x: None)


def test_rv80e_port_depth_clear_of_the_drawn_crank_bores():
    """rv80e's wheel port depth (members range 2-5 mm, cut against the design's own ligament between root circle and
    crank bore) is placed at its Latin-hypercube fraction of the part of that range the drawn crank bores leave:
    draws 21 and 40 of the 64, which failed in the band with the depth in the crank bores (the independent value
    a.at(u) at or beyond the limit), now build their wheel geometry; every depth lies in its cited range and below
    the limit; where the whole range fits, the value is exactly a.at(u); the placement is monotone in u."""
    from rvtool.assembly.wheel_body import port_depth_limit, wheel_geometry
    table, switches, derived, base, members, U = _draws("rv80e", 64)
    keys = [a.key for a in members]
    a = members[keys.index(VM.PORT_DEPTH_KEY)]
    j = len(base) + keys.index(VM.PORT_DEPTH_KEY)
    moved, old_fail = [], []
    for i, u in enumerate(U):
        t = VM.sample_table(table, base, members, u, switches, derived, VM.QUICK_NUMERICS)
        d = design_from_table(t)
        depth, limit = t["wheels"]["structure"]["port_depth"], min(port_depth_limit(d))
        assert a.low <= depth < limit and depth <= a.high, (i, depth, limit)
        if limit >= a.high:
            assert depth == a.at(u[j]), i              # the whole cited range fits: the independent value, bit for bit
        else:
            assert depth == pytest.approx(a.low + u[j] * (limit - a.low), rel=1e-12), i   # the fraction of the part
        if depth != a.at(u[j]):
            moved.append(i)
        if a.at(u[j]) >= limit:
            old_fail.append(i)
            wheel_geometry(d)                             # raised "reaches the crank bores" under the old sampler
    assert old_fail == [21, 40]
    assert len(moved) == 27                               # the draws whose ligament is thinner than the cited range


def test_band_checkpoint_resolves_only_changed_draws(monkeypatch, tmp_path):
    """The checkpoint resumes draw by draw (table digests): a draw whose table changed (here: its recorded digest
    altered) is solved again, the others are kept; a checkpoint without digests is not resumed."""
    import json
    calls, cat, table = _stand_in_rigidity(monkeypatch)
    ck = tmp_path / "ck.json"
    a = VM.members_rigidity("rv40e", table, cat, samples=3, checkpoint=str(ck), checkpoint_out=str(ck),
                            log=lambda *x: None)
    assert len(calls) == 4
    c = json.loads(ck.read_text())
    c["digests"][2] = "changed"
    ck.write_text(json.dumps(c))
    b = VM.members_rigidity("rv40e", table, cat, samples=3, checkpoint=str(ck), checkpoint_out=str(ck),
                            log=lambda *x: None)
    assert len(calls) == 5 and b["sample_values"] == a["sample_values"]
    c = json.loads(ck.read_text())
    del c["digests"]
    ck.write_text(json.dumps(c))
    VM.members_rigidity("rv40e", table, cat, samples=3, checkpoint=str(ck), log=lambda *x: None)
    assert len(calls) == 9


def test_runner_takes_the_band_checkpoint_by_draw_digest(monkeypatch, tmp_path):
    """validate's full run (a UnitRunner) takes members_band's checkpoint by draw digest: the same draws are not
    solved again and give the same band; a draw whose digest differs is solved as a unit; another key (sample
    count) takes nothing."""
    import json
    from rvtool.analysis.workunits import UnitRunner
    calls, cat, table = _stand_in_rigidity(monkeypatch)
    ck = tmp_path / "checkpoint_rv40e.json"
    a = VM.members_rigidity("rv40e", table, cat, samples=3, quick=True, checkpoint_out=str(ck), log=lambda *x: None)
    assert len(calls) == 4
    r = UnitRunner(store=str(tmp_path / "units"))
    b = VM.members_rigidity("rv40e", table, cat, samples=3, quick=True, checkpoint=str(ck), runner=r,
                            log=lambda *x: None)
    assert len(calls) == 4 and b["sample_values"] == a["sample_values"] and b["reused_from_checkpoint"] == 4
    c = json.loads(ck.read_text())
    c["digests"][1] = "changed"
    ck.write_text(json.dumps(c))
    pending = VM.members_rigidity("rv40e", table, cat, samples=3, quick=True, checkpoint=str(ck), runner=r,
                                  defer=True, log=lambda *x: None)
    assert len(calls) == 5                               # submitted (and, serially, run) before the row is asked for
    assert pending()["sample_values"] == a["sample_values"]
    VM.members_rigidity("rv40e", table, cat, samples=2, quick=True, checkpoint=str(ck), runner=r,
                        log=lambda *x: None)
    assert len(calls) == 8                               # samples=2: another key, another LHS: nothing taken


def test_members_tornado_reports_a_derivation_input_by_its_range(monkeypatch):
    """An input of the members' derivation (members.pillar_running_gap: it sets the wheels' pillar holes, it is no
    key of the design table) is reported at the ends of its own range when the screening picks it (session 7: the
    solved tornado of rv40e stopped at it on the GPU host's run)."""
    from rvtool.designs.catalogue import load_assumed, load_catalogue
    gap = "members.pillar_running_gap"
    monkeypatch.setattr(VM, "rigidity_ba", lambda design, catalogue: {"value": 1.0})
    base = load_assumed(designs.assumed_of("rv80e"))
    b, m, _, _ = VM.band_inputs("rv80e", base)
    keys = [a.key for a in b + m]
    U = VM.band_fractions(len(keys), 64, 0)
    values = [100.0 - u[keys.index(gap)] for u in U]
    r = VM.members_tornado("rv80e", read_table(designs.path("rv80e")), load_catalogue(designs.catalogue_of("rv80e")),
                           base, values, keys=1, log=lambda *a: None)
    a = next(x for x in m if x.key == gap)
    assert list(r["tornado"]) == [gap] and (r["tornado"][gap]["low"], r["tornado"][gap]["high"]) == (a.at(0.0), a.at(1.0))


def test_committed_rv80e_band_is_taken_whole_by_its_draw_digests(monkeypatch):
    """The committed band checkpoint (docs/case_results/rv/members_band/checkpoint_rv80e.json) serves
    validate's full run draw by draw: today's sampler and digest (workunits.json_sha256, through table_digest)
    give its 65 recorded draw digests (central + 64), so members_rigidity on a runner solves none of them and
    gives the committed band and central value (a changed digest or sampler would solve the draw here)."""
    import json
    from rvtool.analysis.workunits import UnitRunner
    from rvtool.designs.catalogue import load_assumed, load_catalogue
    folder = Path(__file__).resolve().parents[1] / "docs" / "case_results" / "rv" / "members_band"
    committed = json.loads((folder / "results.json").read_text())["designs"]["rv80e"]
    calls, _, _ = _stand_in_rigidity(monkeypatch)
    r = VM.members_rigidity("rv80e", read_table(designs.path("rv80e")), load_catalogue(designs.catalogue_of("rv80e")),
                            load_assumed(designs.assumed_of("rv80e")), quick=True, samples=VM.SAMPLES,
                            checkpoint=str(folder / "checkpoint_rv80e.json"), runner=UnitRunner(),
                            log=lambda *x: None)
    assert not calls and r["reused_from_checkpoint"] == VM.SAMPLES + 1
    assert r["band"] == committed["band"] and r["central"]["value"] == committed["central"]["value"]
    assert r["sample_values"] == committed["sample_values"]


def test_band_on_units_stops_short_at_the_deadline_and_resumes(monkeypatch, tmp_path):
    """The band runs as units (members_band's path): the deadline passes after two b/a (the stand-in moves the
    runner's deadline into the past), so the band is the draws before the first one not started (short_band)
    and the checkpoint written holds the two finished draws; validate's path (short_band False) raises
    DeadlineReached instead; the same store resumed solves only the two draws left and gives the full band."""
    import json
    from rvtool.analysis.workunits import DeadlineReached, UnitRunner
    calls, cat, table = _stand_in_rigidity(monkeypatch)
    first = UnitRunner(store=str(tmp_path / "units"))
    stand_in = VM.rigidity_ba

    def stops_after_two(design, catalogue):
        out = stand_in(design, catalogue)
        if len(calls) == 2:
            first.deadline = 0.0
        return out
    monkeypatch.setattr(VM, "rigidity_ba", stops_after_two)
    ck = tmp_path / "checkpoint_rv40e.json"
    a = VM.members_rigidity("rv40e", table, cat, samples=3, checkpoint=str(ck), checkpoint_out=str(ck),
                            runner=first, short_band=True, log=lambda *x: None)
    assert len(calls) == 2 and a["samples_done"] == 1 and first.counts["not_started"] == 2
    saved = json.loads(ck.read_text())
    assert saved["of"] == 4 and [r is not None for r in saved["results"]] == [True, True, False, False]
    with pytest.raises(DeadlineReached):
        VM.members_rigidity("rv40e", table, cat, samples=3, runner=first, log=lambda *x: None)
    again = UnitRunner(store=str(tmp_path / "units2"), resume=[str(tmp_path / "units")])
    b = VM.members_rigidity("rv40e", table, cat, samples=3, checkpoint_out=str(ck), runner=again, short_band=True,
                            log=lambda *x: None)
    assert len(calls) == 4 and again.counts == {"run": 2, "reused": 2, "not_started": 0, "failed": 0}
    assert b["samples_done"] == 3 and b["sample_values"][0] == a["sample_values"][0]
    assert all(r is not None for r in json.loads(ck.read_text())["results"])


def test_members_band_redo_takes_the_committed_band_and_writes_it_again(monkeypatch, tmp_path):
    """cases/rv/members_band.py on units with the committed band folder as --resume and rv80e redone: all 65 b/a
    are taken from the committed checkpoint by draw digest (nothing solved), the band is the committed one, and
    the run folder's checkpoint is byte for byte the committed file (the format validate reads is unchanged)."""
    from rvtool import casekit
    folder = Path(__file__).resolve().parents[1] / "docs" / "case_results" / "rv" / "members_band"
    calls, _, _ = _stand_in_rigidity(monkeypatch)
    case = casekit.import_case("rv/members_band")
    r = case.main(["--designs", "rv80e", "--resume", str(folder), "--redo", "rv80e", "--out", str(tmp_path)])
    import json
    committed = json.loads((folder / "results.json").read_text())["designs"]["rv80e"]
    assert not calls and r["designs"]["rv80e"]["reused_from_checkpoint"] == VM.SAMPLES + 1
    assert r["designs"]["rv80e"]["band"] == committed["band"] and r["units"]["run"] == 0
    assert (tmp_path / "checkpoint_rv80e.json").read_bytes() == (folder / "checkpoint_rv80e.json").read_bytes()
