"""``labkit new`` labs of the bundled bus arms (OpenMANIPULATOR-X on Dynamixel, SO-101 on Feetech) on their virtual buses.

Every notebook of both labs runs on ``sim://robot.toml?bus=...``: the vendor SDK (``dynamixel-sdk``,
``feetech-servo-sdk``) sends its packets over a pseudo-terminal to :class:`labkit.arm.bus.BusEmulator`,
which checks each one (header, CRC-16 / checksum, lengths, stuffing). The kernels run in other
processes, so an IPython startup file (``IPYTHONDIR``) records what each emulator saw when it closes.
"""

import ast
import json
import math

import numpy as np
import pytest

from conftest import require
from labkit.exceptions import DeviceError

BUS_ARMS = {"openmanipulator_x": "dynamixel", "so101": "feetech"}

#: IPython startup file of the kernels: each closed BusEmulator appends its packet counts to $LABKIT_TEST_BUS_LOG
RECORDER = """
import json, os
from labkit.arm.bus import BusEmulator

_close = BusEmulator.close

def _recording_close(self):
    counted = getattr(self, "_test_counted", False)
    self._test_counted = True
    _close(self)
    if not counted:
        with open(os.environ["LABKIT_TEST_BUS_LOG"], "a", encoding="utf-8") as f:
            f.write(json.dumps({"cwd": os.getcwd(), "kind": self.bus.PROTOCOL, "packets": len(self.packets),
                                "instructions": sorted({p[0] for p in self.packets}),
                                "sync_writes": self.sync_writes, "rejected": list(self.rejected)}) + "\\n")

BusEmulator.close = _recording_close
"""


@pytest.mark.parametrize("robot", sorted(BUS_ARMS))
def test_a_bus_arm_lab_runs_on_its_virtual_bus(tmp_path, robot):
    from labkit.labs import new_lab
    from labkit.reports import notebook_parameters

    lab = new_lab(robot, tmp_path / robot)
    assert lab.notes == () and lab.lab_robot_file == lab.robot_file, "nothing added to a bus arm's robot file"
    assert not (lab.folder / "robot_with_servos.toml").exists()
    for nb in lab.notebooks[1:]:  # 02..06 drive the arm
        params = notebook_parameters(nb)
        assert ast.literal_eval(params["port"]) == f"sim://robot.toml?bus={BUS_ARMS[robot]}&clock=lockstep&seed=0"
        assert ast.literal_eval(params["robot"]) == "robot.toml"
    text = lab.notebooks[1].read_text()
    assert f'a real bus: \\"{BUS_ARMS[robot]}://' in text
    assert f"bus={BUS_ARMS[robot]}" in (lab.folder / "README.md").read_text()


def test_a_bus_fault_during_a_measurement_stops_the_arm(tmp_path):
    from labkit.arm import Arm
    from labkit.measure import MeasurementSession, PlannedPose

    with Arm("so101", "sim://so101?bus=feetech&clock=lockstep&seed=0") as arm:
        emu = arm.port.emulator
        session = MeasurementSession(arm, tmp_path / "log.csv", source="feedback", readings=1)
        q0 = arm.commanded_joints()
        session.measure(PlannedPose("p00", tuple(q0 + np.radians([10, 5, -5, 5, 0]))))
        assert emu.rejected == [] and len(emu.packets) > 0
        emu.faults.overload.add(arm.robot.links[2].bus.id)  # elbow_flex
        with pytest.raises(DeviceError, match=r"elbow_flex.*overload"):
            session.measure(PlannedPose("p01", tuple(q0 + np.radians([-10, 10, 10, 0, 20]))))
        assert [emu.torque(i) for i in emu.ids] == [False] * 5
        with pytest.raises(DeviceError):
            arm.read_joints()
        session.log.close()
    from labkit.measure import load_measurements

    data = load_measurements(tmp_path / "log.csv")
    assert sorted(data.quantity) == [f"theta{j}" for j in range(1, 6)]  # the first pose only, read from the bus
    assert np.allclose(data.resolution, 360 / 4096)  # one encoder tick [deg]
    assert np.allclose(np.radians(data.value), q0 + np.radians([10, 5, -5, 5, 0]), atol=math.radians(0.5))


def test_the_gripper_of_a_bus_arm_takes_no_pulse_width_and_opens_as_a_bus_servo():
    from labkit.arm import Arm

    with Arm("openmanipulator_x", "sim://openmanipulator_x?bus=dynamixel&clock=lockstep") as arm:
        sent = len(arm.port.emulator.packets)
        with pytest.raises(DeviceError, match="GRIP takes a pulse width: a servo-bus gripper moves with"):
            arm.grip(1500)
        arm.open_gripper()  # the gripper servo (id 15), through the bus (tests/arm/bus/test_gripper.py)
        arm.sleep(0.5)
        assert arm.read_gripper().position == pytest.approx(arm.robot.gripper.open, abs=0.01)
        assert np.allclose(arm.read_joints(), arm.commanded_joints(), atol=math.radians(0.5))  # the arm carries on
        assert len(arm.port.emulator.packets) > sent and arm.port.emulator.rejected == []


@pytest.mark.slow
@pytest.mark.notebooks
def test_both_bus_labs_render_with_every_check_passing_on_checked_sdk_packets(tmp_path, monkeypatch):
    require("papermill")
    from labkit.labs import new_lab
    from labkit.reports import render

    startup = tmp_path / "ipython" / "profile_default" / "startup"
    startup.mkdir(parents=True)
    (startup / "00-record-buses.py").write_text(RECORDER, encoding="utf-8")
    log = tmp_path / "buses.jsonl"
    monkeypatch.setenv("IPYTHONDIR", str(tmp_path / "ipython"))
    monkeypatch.setenv("LABKIT_TEST_BUS_LOG", str(log))
    labs = [new_lab(robot, tmp_path / "labs" / robot) for robot in sorted(BUS_ARMS)]
    results, _ = render([str(lab.folder) for lab in labs], tmp_path / "reports", jobs=2, pdf=False, progress=None,
                        timeout=600)
    failed = [f"{r.lab}/{r.name}: {r.error}" for r in results if not r.ok]
    assert not failed, "\n".join(failed)
    assert len(results) == 16  # 8 notebooks each (both files carry inertias: 07_dynamics)
    seen = [json.loads(line) for line in log.read_text().splitlines()]
    for kind in BUS_ARMS.values():
        runs = [s for s in seen if s["kind"] == kind]
        # one bus per `with Arm(...)`: 02, 03, 04, 05, 06 and 07 open the arm once each, 08 three times (the step,
        # the servo's own loop with its gains changed, the resolved-rate line)
        assert len(runs) == 9, (kind, runs)
        for s in runs:
            assert s["rejected"] == [], s  # every packet the SDK sent was intact
            assert s["packets"] > 100 and s["sync_writes"] > 10, s
            assert {"ping", "write", "sync write", "sync read"} <= set(s["instructions"]), s
