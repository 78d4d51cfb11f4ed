"""``hitchpark export`` and ``sil`` on the command line: what they write, and bad input refused in one line."""

from __future__ import annotations

import json

import pytest

from hitchpark.cli import EXIT_BAD_INPUT, main


def test_export_writes_the_package_and_refuses_to_overwrite_a_folder(tmp_path, capsys):
    out = tmp_path / "pkg"
    assert main(["export", "--out", str(out), "--scenario", "parallel"]) == 0
    assert (out / "include" / "hitchpark_nmpc.h").is_file() and (out / "Makefile").is_file()
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["settings"]["example"]["scenario"] == "parallel"
    assert not [p for p in out.iterdir() if p.name.startswith(".hitchpark-staging")]
    capsys.readouterr()
    assert main(["export", "--out", str(out)]) == EXIT_BAD_INPUT
    assert "not empty" in capsys.readouterr().err
    (out / "mine.txt").write_text("keep me")
    assert main(["export", "--out", str(out), "--force"]) == 0
    assert (out / "mine.txt").read_text() == "keep me"


@pytest.mark.parametrize(
    "args, message",
    [
        (["--obstacles", "--settings", "NOPLANES"], "obstacle_planes of 1 or more"),
        (["--scenario", "nosuch"], "nosuch"),
        (["--settings", "PAPER"], "nmpc.kind 'full'"),
        (["--settings", "SQP"], "riccati_c"),
    ],
)
def test_export_refuses_bad_input_in_one_line(args, message, tmp_path, capsys):
    (tmp_path / "paper.toml").write_text('[nmpc]\nkind = "paper"\n')
    (tmp_path / "sqp.toml").write_text('[nmpc]\nsolver = "sqp"\n')
    (tmp_path / "noplanes.toml").write_text("[nmpc]\nobstacle_planes = 0\n")
    names = {
        "PAPER": str(tmp_path / "paper.toml"),
        "SQP": str(tmp_path / "sqp.toml"),
        "NOPLANES": str(tmp_path / "noplanes.toml"),
    }
    args = [names.get(a, a) for a in args]
    assert main(["export", "--out", str(tmp_path / "pkg"), *args]) == EXIT_BAD_INPUT
    err = capsys.readouterr().err
    assert message in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "pkg").exists() or not any((tmp_path / "pkg").iterdir())


def test_sil_refuses_bad_input_in_one_line(tmp_path, capsys):
    assert main(["sil", "--scenario", "nosuch", "--json", str(tmp_path / "s.json")]) == EXIT_BAD_INPUT
    assert "nosuch" in capsys.readouterr().err
    assert not (tmp_path / "s.json").exists()
    (tmp_path / "paper.toml").write_text('[nmpc]\nkind = "paper"\n')
    (tmp_path / "success.toml").write_text("[success]\nmax_stages = 3\n")
    for settings, message in (
        (tmp_path / "none.toml", "cannot read settings file"),
        (tmp_path / "paper.toml", "nmpc.kind 'full'"),
        (tmp_path / "success.toml", "sil takes its [nmpc] and [estimator] tables, not [success]"),
    ):
        argv = ["sil", "--scenario", "random", "--settings", str(settings), "--json", str(tmp_path / "s.json")]
        assert main(argv) == EXIT_BAD_INPUT
        err = capsys.readouterr().err
        assert message in err and len(err.strip().splitlines()) == 1
        assert not (tmp_path / "s.json").exists()


def test_the_real_time_iteration_setting_goes_into_the_package_and_nowhere_by_default(tmp_path):
    """``[nmpc.solver_options] warm_iterations`` and ``whole_steps_only`` (benchmarks/settings/realtime_iteration.toml)
    define HP_WARM_ITER and HP_WARM_WHOLE in each OCP's file of the package; the default package has neither (its
    solver is the in-process default's)."""
    from pathlib import Path

    settings = Path(__file__).parents[2] / "benchmarks" / "settings" / "realtime_iteration.toml"
    for args, defined in (([], False), (["--settings", str(settings)], True)):
        out = tmp_path / ("rti" if defined else "default")
        assert main(["export", "--out", str(out), *args]) == 0
        for ocp in ("park", "track"):
            text = (out / "src" / f"hitchpark_nmpc_ocp_{ocp}.c").read_text()
            assert ("#define HP_WARM_ITER 1\n" in text) == defined
            assert ("#define HP_WARM_WHOLE 1\n" in text) == defined
        manifest = json.loads((out / "manifest.json").read_text())
        options = {"warm_iterations": 1, "whole_steps_only": True}
        assert manifest["settings"]["nmpc"]["solver_options"] == (options if defined else {})


def test_sil_takes_the_settings_files_estimator_for_both_runs(tmp_path, monkeypatch):
    """``sil --settings`` with an [estimator] table (benchmarks/settings/hitch_sensor.toml): both runs filter the
    readings with it (the scenario's estimator replaced), and the NMPC stays the scenario's where the file has no
    [nmpc] table."""
    from pathlib import Path

    import hitchpark.app.sil as sil_module

    seen = {}

    def fake_run_sil(scenario, nmpc=None, process=None):
        seen.update(scenario=scenario, nmpc=nmpc)
        raise SystemExit(0)

    monkeypatch.setattr(sil_module, "run_sil", fake_run_sil)
    settings = Path(__file__).parents[2] / "benchmarks" / "settings" / "hitch_sensor.toml"
    with pytest.raises(SystemExit):
        main(["sil", "--scenario", "curb_parallel", "--settings", str(settings), "--json", str(tmp_path / "s.json")])
    assert seen["scenario"].settings.estimator.hitch_noise_std_deg == 0.5
    assert seen["nmpc"] is None
