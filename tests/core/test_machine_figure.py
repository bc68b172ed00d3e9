"""Timings that travel (issue 28): every benchmark's JSON carries machine_speed's torch_step_s, and its timings
in reference steps."""
import json
import subprocess
import sys

from lapig.tools.bench import machine_figure


def test_timings_get_their_reference_steps_beside_them():
    speed = {"torch_step_s": 0.25, "cpu": "AMD EPYC", "cores": 2}
    out = machine_figure.with_machine_figures(
        {"total_s": 100.0, "capture_seconds": 5.0, "ratio": 1.1, "flag_s": True, "name_s": "x"}, speed)
    assert out["torch_step_s"] == 0.25 and out["machine_speed"] == speed
    assert out["total_s_steps"] == 400.0 and out["capture_seconds_steps"] == 20.0
    assert "ratio_steps" not in out and "flag_s_steps" not in out and "name_s_steps" not in out
    assert out["total_s"] == 100.0  # the seconds stay


def test_without_a_measured_step_the_seconds_stand_alone():
    out = machine_figure.with_machine_figures({"total_s": 3.0}, {"torch_step_s": None, "machine_speed_error": "x"})
    assert out["torch_step_s"] is None and "total_s_steps" not in out


def test_a_failing_measurement_is_a_message_not_an_exception(monkeypatch):
    def broken(*a, **k):
        return subprocess.CompletedProcess(a, 1, stdout="", stderr="Traceback...\nImportError: no torch\n")
    monkeypatch.setattr(machine_figure.subprocess, "run", broken)
    out = machine_figure.machine_speed()
    assert out["torch_step_s"] is None and out["machine_speed_error"] == "ImportError: no torch"


def test_the_script_ends_with_one_json_line_of_the_figures(monkeypatch, capsys):
    """The real measurement is `bench machine` (seconds to minutes by the machine's load); here, its output is
    read from the script run with the workloads replaced by instant ones."""
    import runpy

    script = runpy.run_path(machine_figure.SCRIPT, run_name="not_main")
    monkeypatch.setitem(script["main"].__globals__, "torch_step_seconds", lambda *a, **k: (0.5, "2.13.0"))
    monkeypatch.setitem(script["main"].__globals__, "numpy_matmul_seconds", lambda *a, **k: 0.01)
    script["main"]()
    figures = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert figures["torch_step_s"] == 0.5 and figures["numpy_matmul_s"] == 0.01


def _fake_cpus(root, cores):
    """sysfs' cpu folders for logical CPUs on (package, core) pairs, and a cpuinfo."""
    for i, (package, core) in enumerate(cores):
        topology = root / "cpu" / f"cpu{i}" / "topology"
        topology.mkdir(parents=True)
        (topology / "core_id").write_text(f"{core}\n")
        (topology / "physical_package_id").write_text(f"{package}\n")
    (root / "cpu" / "cpufreq").mkdir()  # not a CPU: left out
    info = root / "cpuinfo"
    info.write_text("".join(f"processor\t: {i}\nmodel name\t: Intel(R) Xeon(R) Platinum 8375C CPU @ 2.90GHz\n\n"
                            for i in range(len(cores))))
    return str(root / "cpu"), str(info)


def test_the_topology_says_when_two_cpus_are_one_cores_two_hyperthreads(tmp_path):
    one_core = machine_figure.cpu_topology(*_fake_cpus(tmp_path / "a", [(0, 0), (0, 0)]))
    assert one_core == {"logical_cpus": 2, "physical_cores": 1, "threads_per_core": 2.0,
                        "model": "Intel(R) Xeon(R) Platinum 8375C CPU @ 2.90GHz"}
    two_cores = machine_figure.cpu_topology(*_fake_cpus(tmp_path / "b", [(0, 0), (0, 1)]))
    assert two_cores["physical_cores"] == 2 and two_cores["threads_per_core"] == 1.0
    assert machine_figure.cpu_topology(str(tmp_path / "none"), str(tmp_path / "none")) == {}


def test_this_machines_topology_travels_with_the_speed(monkeypatch):
    def fine(*a, **k):
        return subprocess.CompletedProcess(a, 0, stdout='{"torch_step_s": 0.1}\n', stderr="")
    monkeypatch.setattr(machine_figure.subprocess, "run", fine)
    out = machine_figure.machine_speed()
    assert out["torch_step_s"] == 0.1 and out["topology"] == machine_figure.cpu_topology()
