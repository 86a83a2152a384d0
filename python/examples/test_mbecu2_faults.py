# SPDX-License-Identifier: BSD-3-Clause
"""ECU tests as pytest functions: MBecu2 (psecu2 on NEDC) under faults, judged on verdicts
and numpy columns. Run with Debian's pytest, the module on PYTHONPATH:

    PYTHONPATH=build/python /usr/bin/python3 -m pytest -q python/examples/test_mbecu2_faults.py

Each test runs a scenario with a fault (ehpt.run(..., faults=[...]), the same text as
`ehpt run --fault`) or a test file of examples/tests/ (its [[fault]] and [[expect]] tables),
and asserts on summary["test"] (the verdict ehpt computed at every plant step) and on the
recorded columns, faults_active included.
"""
import os

import numpy as np
import pytest

import ehpt

HERE = os.path.dirname(os.path.abspath(__file__))
TESTS = os.path.join(HERE, "..", "..", "examples", "tests")
SHORT = {"solver.duration_s": 200, "output.interval_s": 0.01}


def test_the_shipped_soc_sensor_test_passes():
    r = ehpt.run(os.path.join(TESTS, "soc_sensor_stuck.toml"))
    assert r.exit_code == 0
    assert r.summary["test"]["verdict"] == "passed"
    assert all(e["passed"] for e in r.summary["test"]["expectations"])


def test_no_start_keeps_the_engine_off_from_its_time():
    r = ehpt.run("psecu2_nedc", set=SHORT, faults=["kind=no_start at_s=50"])
    t, on, bits = r.timeseries["time_s"], r.timeseries["iceON"], r.timeseries["faults_active"]
    assert np.all(on[t >= 50.0] == 0.0)
    assert np.array_equal(bits, (t >= 50.0 - 1e-9).astype(float))
    healthy = ehpt.run("psecu2_nedc", set=SHORT)
    assert healthy.summary["fuel_g"] > r.summary["fuel_g"]  # the healthy engine burned fuel after 50 s


def test_a_gen_torque_clamp_holds_at_every_recorded_row():
    r = ehpt.run("psecu2_nedc", set=SHORT, faults=["kind=saturate target=genTauRef_Nm limit=5 at_s=0"])
    assert np.max(np.abs(r.timeseries["gen_torque_Nm"])) <= 5.0


def test_the_test_written_to_fail_fails_its_soc_band():
    r = ehpt.run(os.path.join(TESTS, "soc_stuck_written_to_fail.toml"))
    test = r.summary["test"]
    assert test["expect_fail"] and test["verdict"] == "passed"  # an expected failure
    band = next(e for e in test["expectations"] if e["name"] == "soc_band")
    assert not band["passed"] and band["value"] < 0.53 and 300.0 < band["time_s"] < 340.0


def test_an_outside_ecu_reads_the_faulted_sensor():
    sim = ehpt.Simulation("psecu2_nedc", set={"solver.duration_s": 30}, external_ecu=True,
                          faults=["kind=fixed target=batSOC value=0.42 at_s=10"])
    seen = []
    while not sim.finished:
        s = sim.read_sensors()
        seen.append((s.stamp.time_s, s.batSOC))
        sim.write_command(ehpt.PsdCommand(motTauRef_Nm=60.0 * s.driverRequest, iceON=False))
        sim.step(sim.ecu_period_steps)
    assert all(soc == 0.42 for t, soc in seen if t >= 10.0)
    assert all(soc != 0.42 for t, soc in seen if t < 10.0)


def test_command_frames_lost_on_the_bus_put_the_plant_in_its_safe_state():
    # a bus fault acts on CAN frames: ehpt.run puts the built-in ECU on an in-process CAN bus
    r = ehpt.run("psecu2_nedc", set={"solver.duration_s": 14},
                 faults=["kind=drop target=PsdCommand1 at_s=12.0 until_s=12.05"])
    bus = r.summary["bus"]
    assert r.exit_code == 0 and bus["transport"] == "in-process"
    assert bus["faults"] == [{"kind": "drop", "message": "PsdCommand1", "direction": "ecu_to_plant", "frames": 5}]
    assert bus["timeouts"] == 1 and bus["timeouts_under_bus_faults"] == 1
    t, mot = r.timeseries["time_s"], r.timeseries["motTauRef_Nm"]
    lost = (t > 12.0215) & (t < 12.0495)  # the command timed out (3 ECU periods) until the frames come again
    assert np.all(mot[lost] == 0.0) and mot[np.searchsorted(t, 12.0)] != 0.0


def test_a_bad_fault_is_an_error_naming_it():
    with pytest.raises(ehpt.Error) as err:
        ehpt.run("psecu2_nedc", faults=["kind=stuk target=batSOC"])
    assert 'did you mean "stuck"' in str(err.value)
    with pytest.raises(TypeError):
        ehpt.run("psecu2_nedc", faults="kind=stuck target=batSOC")


def test_a_simulation_gives_its_verdict_as_it_stands_and_at_the_end_the_runs():
    path = os.path.join(TESTS, "battery_r0_doubled.toml")
    sim = ehpt.Simulation(path)
    sim.step(50000)  # 50 s of 400
    mid = sim.verdict()
    assert mid["verdict"] == "incomplete" and mid["finished"] is False  # never "passed" before the end
    assert not mid["all_expectations_held"]  # the windows to the end are not reached yet
    while not sim.finished:
        sim.step(sim.chunk_steps)
    end = sim.verdict()
    assert end["finished"] is True and end["verdict"] == "passed"
    r = ehpt.run(path)
    want = dict(r.summary["test"], finished=True)
    assert end == want  # the same verdict as the batch run's, every expectation and span
    assert [f["kind"] for f in end["faults"]] == ["r0_gain"] and end["faults"][0]["active_steps"] == 400001
    # a verdict mid-run changed nothing: the same final outputs as a run never asked
    plain = ehpt.Simulation(path)
    plain.run()
    assert plain.outputs() == sim.outputs()
    assert ehpt.Simulation("psecu2_nedc", set=SHORT).verdict() is None  # no test, no verdict


def test_a_failing_simulation_names_its_first_failure():
    sim = ehpt.Simulation(os.path.join(TESTS, "soc_stuck_written_to_fail.toml"))
    sim.run()
    v = sim.verdict()
    assert v["verdict"] == "passed" and v["expect_fail"] is True  # written to fail: it failed
    assert v["all_expectations_held"] is False and v["first_failure"].startswith("soc_band:")
