"""Command line: help, case listing, unknown-case error and an in-process run of a dummy case."""
import json
import textwrap

import pytest

from rvtool import cli

DUMMY_CASE = textwrap.dedent('''\
    """Dummy case for the command-line tests.

    Second docstring line, not listed.
    """
    import time

    from rvtool import casekit


    def main(argv=None):
        args = casekit.parse_args(argv, __doc__)
        t0 = time.perf_counter()
        results = {"quick": args.quick}
        return casekit.write_results(args.out, results, settings={"quick": args.quick},
                                     wall_s=time.perf_counter() - t0)


    if __name__ == "__main__":
        main()
''')


@pytest.fixture
def case_folder(tmp_path, monkeypatch):
    """A cases folder with one dummy case and one helper file, selected through RVTOOL_CASES."""
    folder = tmp_path / "cases"
    folder.mkdir()
    (folder / "dummy.py").write_text(DUMMY_CASE)
    (folder / "_helper.py").write_text('"""Helper module, not a case."""\n')
    monkeypatch.setenv(cli.CASES_ENV, str(folder))
    monkeypatch.chdir(tmp_path)
    return folder


def test_help(capsys):
    with pytest.raises(SystemExit) as exc:
        cli.main(["--help"])
    assert exc.value.code == 0
    out = capsys.readouterr().out
    for command in ("list", "run", "version"):
        assert command in out


def test_list_repository_cases(capsys, monkeypatch):
    monkeypatch.delenv(cli.CASES_ENV, raising=False)
    names = cli.discover_cases()
    assert names, "the repository's cases/ folder holds no case"
    assert cli.main(["list"]) == 0
    out = capsys.readouterr().out
    group, _, stem = names[0].rpartition("/")
    assert f"{group}/" in out and stem in out


def test_list_shows_name_and_first_docstring_line(case_folder, capsys):
    assert cli.main(["list"]) == 0
    out = capsys.readouterr().out
    assert "dummy" in out
    assert "Dummy case for the command-line tests." in out
    assert "Second docstring line" not in out
    assert "_helper" not in out


def test_unknown_case_exits_2_and_names_available_cases(case_folder, capsys):
    with pytest.raises(SystemExit) as exc:
        cli.main(["run", "no_such_case"])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert "no_such_case" in err
    assert "dummy" in err


def test_run_writes_results(case_folder, tmp_path, capsys):
    out = tmp_path / "out"
    assert cli.main(["run", "dummy", "--quick", "--out", str(out)]) == 0
    data = json.loads((out / "results.json").read_text())
    assert data["quick"] is True
    assert "provenance" in data
    assert str(out / "results.json") in capsys.readouterr().out


def test_run_without_case_runs_the_short_reducer_study(tmp_path, monkeypatch):
    # no cases folder needed (a wheel has none): the bare command analyses the shipped design
    monkeypatch.setenv(cli.CASES_ENV, str(tmp_path / "no_cases_here"))
    monkeypatch.chdir(tmp_path)
    assert cli.main(["run"]) == 0
    design, protocols = cli.DEFAULT_STUDY
    data = json.loads((tmp_path / "results" / f"analyze_{design}" / "results.json").read_text())
    assert data["quick"] is True
    assert data["protocols"] == protocols.split(",")
    assert (tmp_path / "results" / f"analyze_{design}" / "report.html").is_file()


def test_version(capsys):
    assert cli.main(["version"]) == 0
    out = capsys.readouterr().out
    assert "rvtool:" in out
    assert "exudyn:" in out


def test_list_groups_by_folder_and_run_accepts_bare_and_grouped_names(tmp_path, monkeypatch, capsys):
    folder = tmp_path / "cases"
    (folder / "alpha").mkdir(parents=True)
    (folder / "beta").mkdir()
    (folder / "alpha" / "one.py").write_text(DUMMY_CASE)
    (folder / "beta" / "two.py").write_text(DUMMY_CASE)
    (folder / "beta" / "_helper.py").write_text('"""Helper module, not a case."""\n')
    monkeypatch.setenv(cli.CASES_ENV, str(folder))
    monkeypatch.chdir(tmp_path)
    assert cli.discover_cases() == ["alpha/one", "beta/two"]
    assert cli.main(["list"]) == 0
    out = capsys.readouterr().out
    assert out.index("alpha/") < out.index("one") < out.index("beta/") < out.index("two")
    assert "_helper" not in out
    for name in ("two", "beta/two", "beta/two.py", "cases/beta/two.py"):
        assert cli.resolve_case(name) == "beta/two"
    out_dir = tmp_path / "o"
    assert cli.main(["run", "alpha/one", "--out", str(out_dir)]) == 0
    assert (out_dir / "results.json").is_file()
    assert cli.main(["run", "two", "--quick"]) == 0
    assert json.loads((tmp_path / "results" / "two" / "results.json").read_text())["quick"] is True


def test_ambiguous_bare_case_name_exits_2_naming_both(tmp_path, monkeypatch, capsys):
    folder = tmp_path / "cases"
    for group in ("a", "b"):
        (folder / group).mkdir(parents=True)
        (folder / group / "same.py").write_text(DUMMY_CASE)
    monkeypatch.setenv(cli.CASES_ENV, str(folder))
    with pytest.raises(SystemExit) as exc:
        cli.main(["run", "same"])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert "a/same" in err and "b/same" in err
