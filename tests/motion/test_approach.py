"""Tests of approach points "above" in world terms (labkit.motion._approach) and the robot's up direction.

The end-to-end test runs the two-stage pick and place on the virtual arm and checks, on the
positions the simulated arm really reaches (its ruler and true end effector), that every
approach point lies above its object and that the legs ending at the object and at the place
descend all the way (seed 000 IV.3: ``pick + (0, 0, +0.05)`` was 5 cm *below* the object on
this arm, whose frame 0 has z pointing down).
"""

import numpy as np
import pytest

from labkit.arm import Arm, PhysicsConfig, gravity_sag, segments_from_trajectory
from labkit.exceptions import OptionError, ShapeError
from labkit.kinematics import fk_position
from labkit.motion import approach_point, cartesian_trajectory, height_above, line_path, pick_and_place_legs
from labkit.robot import Robot

SIM = "sim://?clock=lockstep&seed=0"
ARM = Robot.load("arduino_arm_3dof")
# the seed's start point and two of its video targets (IV.3) as object and drop point
HOME, PICK, PLACE = np.array([0.0, 0.18, -0.094]), np.array([0.20, 0.10, -0.10]), np.array([-0.20, 0.10, -0.10])


def test_up_of_the_seed000_arm_is_minus_z0_and_matches_the_virtual_gravity():
    assert np.array_equal(ARM.up, [0.0, 0.0, -1.0])
    # the simulated physics pulls the other way: its default gravity is -9.81 up, +z0 on this arm
    assert PhysicsConfig().gravity is None
    q = np.radians([0, 20, 10])
    np.testing.assert_array_equal(gravity_sag(ARM, q), gravity_sag(ARM, q, PhysicsConfig(gravity=(0, 0, 9.81))))
    # the arm's highest point (q2 = 90 deg, link straight up) has the largest height
    q = np.radians([[0, 90, 0], [0, 60, 0], [0, 5, 0]])
    h = height_above(ARM, fk_position(ARM, q))
    assert h[0] == pytest.approx(0.274) and h[0] > h[1] > h[2]


def test_approach_point_is_above_along_up_and_batches():
    above = approach_point(ARM, PICK, 0.05)
    assert np.allclose(above, PICK + [0.0, 0.0, -0.05])
    assert height_above(ARM, above, PICK) == pytest.approx(0.05)
    # the seed's formula is below the object on this arm
    assert height_above(ARM, PICK + [0.0, 0.0, 0.05], PICK) == pytest.approx(-0.05)
    batch = approach_point(ARM, np.stack([PICK, PLACE]), [0.05, 0.02])
    assert batch.shape == (2, 3)
    assert np.allclose(height_above(ARM, batch, np.stack([PICK, PLACE])), [0.05, 0.02])
    z_up = Robot.load("puma_wrist_seed002")  # default up: +z
    assert np.allclose(approach_point(z_up, [0.1, 0.0, 0.4], 0.01), [0.1, 0.0, 0.41])


@pytest.mark.parametrize("height", [0.0, -0.05, float("nan")])
def test_approach_height_must_be_positive(height):
    with pytest.raises(OptionError, match="positive approach height"):
        approach_point(ARM, PICK, height)


def test_approach_shapes_are_checked():
    with pytest.raises(ShapeError, match="target"):
        approach_point(ARM, [0.1, 0.2], 0.05)
    with pytest.raises(ShapeError, match="height"):
        approach_point(ARM, np.stack([PICK, PLACE]), [0.01, 0.02, 0.03])


def test_legs_chain_and_descend_onto_object_and_place():
    legs = pick_and_place_legs(ARM, HOME, PICK, PLACE, 0.05)
    assert len(legs) == 7
    for a, b in zip(legs, legs[1:]):
        assert np.array_equal(a.end, b.start)
    assert np.array_equal(legs[0].start, HOME) and np.array_equal(legs[-1].end, HOME)
    down = [leg for leg in legs if leg.gripper]
    assert [leg.gripper for leg in down] == ["close", "open"]
    assert np.allclose([height_above(ARM, leg.start, leg.end) for leg in down], 0.05)
    assert np.allclose(down[0].end, PICK) and np.allclose(down[1].end, PLACE)


@pytest.mark.slow
def test_pick_and_place_on_the_virtual_arm_approaches_from_above():
    """Measured on the simulated arm: approach points above their objects, final legs descending."""
    legs = pick_and_place_legs(ARM, HOME, PICK, PLACE, 0.05)
    # 1 s for the short final legs, 2 s for the others: at 1 s the pick-to-place leg needs 4,200 deg/s^2
    # at the shoulder, over the robot file's 1,500, and the link refuses to send it
    plans = [cartesian_trajectory(ARM, line_path(leg.start, leg.end), 1.0 if leg.gripper else 2.0, dt=0.1,
                                  branch="elbow_up") for leg in legs]
    stops, descents = [], {}
    with Arm(ARM, SIM) as arm:
        sim = arm.virtual_model
        arm.set_host_timeout(5.0)
        arm.move_joints(plans[0].q[0], wait=True)
        for leg, plan in zip(legs, plans):
            if leg.gripper:  # sample the real path of the final legs while they run
                arm.run_trajectory(segments_from_trajectory(plan, min_duration=0.2), wait=False)  # fits the queue
                samples = []
                for _ in range(16):  # 1.6 s of board time for a 1 s leg
                    arm.sleep(0.1)
                    samples.append(sim.end_effector())
                descents[leg.gripper] = np.array(samples)
            else:
                arm.run_trajectory(plan, wait=True)
            arm.wait_settled(plan.q[-1], tol=np.radians(2.0))
            stops.append(sim.ruler(3).mean(axis=0))
        arm.set_host_timeout(0.5)
    stops = np.array(stops)
    objects = {"close": 1, "open": 4}  # index of the stop at the object / at the place
    for grip, i in objects.items():
        above, at = stops[i - 1], stops[i]
        # the approach point, as measured, lies above the object as measured (planned 50 mm)
        assert height_above(ARM, above, at) == pytest.approx(0.05, abs=0.005)
        # the object is reached where it was planned (servo zero offsets ~1 deg and gravity sag at
        # this reach: within 20 mm)
        assert np.linalg.norm(at - legs[i].end) < 0.020
        h = height_above(ARM, descents[grip], at)
        assert h[0] == pytest.approx(0.05, abs=0.005), "the final leg starts at the approach point"
        assert np.all(np.diff(h) < 5e-4), f"the final leg to the {grip} point rises: {np.round(h * 1e3, 1)} mm"
        assert h.min() > -0.002, "the gripper went below the object before reaching it"
        assert abs(h[-1]) < 0.002
