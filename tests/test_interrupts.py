"""Ctrl-C and SIGTERM while `crowdmotion run` writes its files, as a user meets them."""

import json
import os
import signal

import pyarrow.parquet as pq
import pytest

from crowdmotion.cli import main
from tests.test_scenario import GOOD


def _signal_while_writing_trajectories(monkeypatch, sig, times: int) -> None:
    """The trajectories' writer receives ``sig`` ``times`` times as it starts writing."""
    real = pq.write_table

    def write_table(table, where, **kwargs):
        for _ in range(times):
            os.kill(os.getpid(), sig)
            for _ in range(1000):  # a few lines of Python: the handler runs among them
                pass
        real(table, where, **kwargs)

    monkeypatch.setattr(pq, "write_table", write_table)


@pytest.mark.parametrize("sig,code,name", [(signal.SIGINT, 130, "Ctrl-C"), (signal.SIGTERM, 143, "SIGTERM")])
def test_an_interrupt_while_the_files_are_written_lets_them_finish_whole(tmp_path, monkeypatch, capsys, sig, code,
                                                                         name):
    from crowdmotion import Trajectories

    path = tmp_path / "s.toml"
    path.write_text(GOOD)
    out = tmp_path / "out"
    _signal_while_writing_trajectories(monkeypatch, sig, 1)
    before = signal.getsignal(sig)
    assert main(["run", str(path), "-o", str(out), "-q", "--plots", "paths"]) == code
    assert signal.getsignal(sig) is before, "the command gives back the handler it found"
    err = capsys.readouterr().err
    assert f"{name}: finishing the files" in err and "written whole" in err and "Traceback" not in err, err
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["complete"] is True and manifest["partial"] is False  # the simulation had finished
    assert sorted(manifest["files"]) == ["paths.png", "summary.json", "trajectories.parquet"]
    assert Trajectories.load(out / "trajectories.parquet").n_frames == json.loads(
        (out / "summary.json").read_text())["frames"]
    assert sorted(p.name for p in out.iterdir()) == ["manifest.json", "paths.png", "summary.json",
                                                    "trajectories.parquet"]


def test_a_second_interrupt_while_writing_keeps_none_of_the_runs_files(tmp_path, monkeypatch, capsys):
    path = tmp_path / "s.toml"
    path.write_text(GOOD)
    out = tmp_path / "out"
    _signal_while_writing_trajectories(monkeypatch, signal.SIGINT, 2)
    assert main(["run", str(path), "-o", str(out), "-q", "--plots", "paths"]) == 130
    err = capsys.readouterr().err
    assert "no file of this run is left" in err and "Traceback" not in err, err
    assert not out.exists() or list(out.iterdir()) == []
    monkeypatch.undo()
    assert main(["run", str(path), "-o", str(out), "-q", "--plots", "paths"]) == 0  # the retry needs no --overwrite


def test_an_interrupt_after_the_last_step_keeps_the_whole_run(tmp_path, monkeypatch, capsys):
    import crowdmotion.metrics

    path = tmp_path / "s.toml"
    path.write_text(GOOD)
    out = tmp_path / "out"
    real = crowdmotion.metrics.summary

    def summary(*args, **kwargs):  # the run measures its frames when SIGTERM comes
        os.kill(os.getpid(), signal.SIGTERM)
        for _ in range(1000):
            pass
        return real(*args, **kwargs)

    monkeypatch.setattr(crowdmotion.metrics, "summary", summary)
    assert main(["run", str(path), "-o", str(out), "-q", "--plots", "none"]) == 143
    err = capsys.readouterr().err
    assert "SIGTERM: the simulation had finished" in err and "written whole" in err and "Traceback" not in err, err
    assert json.loads((out / "summary.json").read_text())["partial"] is False
    assert json.loads((out / "manifest.json").read_text())["complete"] is True


def test_an_interrupt_before_the_simulation_leaves_nothing(tmp_path, monkeypatch, capsys):
    import crowdmotion.scenario

    path = tmp_path / "s.toml"
    path.write_text(GOOD)
    out = tmp_path / "out"
    real = crowdmotion.scenario.run_scenario

    def run_scenario(*args, **kwargs):  # SIGTERM while the run sets up, before its first step
        os.kill(os.getpid(), signal.SIGTERM)
        for _ in range(1000):
            pass
        return real(*args, **kwargs)  # pragma: no cover

    monkeypatch.setattr(crowdmotion.scenario, "run_scenario", run_scenario)
    assert main(["run", str(path), "-o", str(out), "-q"]) == 143
    assert "SIGTERM: stopped; no file of this run is left" in capsys.readouterr().err
    assert not out.exists()


def _kernel_interrupted_on(monkeypatch, step: int, cause: BaseException) -> None:
    """The RVO simulator's ``step`` call number ``step`` fails as a compiled kernel does when
    a signal lands as it returns: CPython raises SystemError from the handler's exception."""
    from crowdmotion.rvo.simulator import Simulator

    real, calls = Simulator.step, []

    def step_(self, *args, **kwargs):
        calls.append(1)
        if len(calls) == step:
            try:
                raise cause
            except BaseException as exc:
                raise SystemError("CPUDispatcher(<function build_grid>) returned a result with an exception set") \
                    from exc
        return real(self, *args, **kwargs)

    monkeypatch.setattr(Simulator, "step", step_)


RVO_RUN = GOOD.replace('method = "mdp"', 'method = "rvo"').replace("[mdp]", "[rvo]")


def test_ctrl_c_landing_in_a_compiled_kernel_keeps_the_frames_so_far(tmp_path, monkeypatch, capsys):
    path = tmp_path / "s.toml"
    path.write_text(RVO_RUN)
    out = tmp_path / "out"
    _kernel_interrupted_on(monkeypatch, 6, KeyboardInterrupt())
    assert main(["run", str(path), "-o", str(out), "-q", "--plots", "none"]) == 130
    err = capsys.readouterr().err
    assert "kept the 6 frames simulated so far" in err and "internal error" not in err, err
    summary = json.loads((out / "summary.json").read_text())
    assert summary["partial"] is True and summary["frames"] == 6


def test_ctrl_c_landing_in_a_compiled_kernel_keeps_the_frames_in_the_python_api(monkeypatch):
    from crowdmotion.scenario import parse_scenario
    from crowdmotion import rvo

    sc = parse_scenario(RVO_RUN)
    _kernel_interrupted_on(monkeypatch, 4, KeyboardInterrupt())
    traj = rvo.simulate(sc.scene, sc.groups, sc.params)
    assert traj.metadata["partial"] is True and traj.positions.shape[0] == 4


def test_a_system_error_of_ours_is_still_an_internal_error(tmp_path, monkeypatch, capsys):
    path = tmp_path / "s.toml"
    path.write_text(RVO_RUN)
    _kernel_interrupted_on(monkeypatch, 3, ValueError("a kernel's own failure"))
    assert main(["run", str(path), "-o", str(tmp_path / "out"), "-q", "--plots", "none"]) == 1
    assert "internal error: SystemError" in capsys.readouterr().err
