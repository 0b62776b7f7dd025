"""The webcam path (:class:`VideoSource`, ``cv2.VideoCapture``) on a recorded MJPG video with known truth.

There is no webcam on the test machines, so the virtual camera records one: at each pose of a
plan on ``sim://`` it writes what a webcam with a frame queue delivers after the arm moved
(``STALE`` frames still showing the previous pose, then fresh ones) into an MJPG video (the
format USB webcams send), with the gripper's true position. A camera session then reads that
video through the real ``cv2.VideoCapture`` code of :class:`VideoSource`.
"""

import dataclasses

import cv2
import numpy as np
import pytest

from labkit.arm import Arm
from labkit.exceptions import DeviceError, LabkitError
from labkit.measure import joint_sweep_plan, load_measurements
from labkit.vision import CameraRig, CameraSession, VideoSource, VisionError

PLAN = joint_sweep_plan("arduino_arm_3dof", {1: [20, 100], 2: [45, 90], 3: [60]})
URL = "sim://?clock=lockstep&seed=0"
STALE, WARMUP, FRAMES = 3, 1, 2  # queued frames of the previous pose, warm-up, kept per pose


class _Recorder:
    """A frame source that records what a queued webcam would deliver, and the truth."""

    def __init__(self, camera, writer):
        self.camera, self.writer = camera, writer
        self.previous = camera.capture()  # the arm before the first move
        self.truth = {}

    def frames(self, pose_id, count):
        fresh = self.camera.frames(pose_id, WARMUP + count)
        for img in [self.previous] * STALE + fresh:
            self.writer.write(img)
        self.previous = fresh[-1]
        self.truth[pose_id] = self.camera.true_base_from_tool()[:3, 3]
        return fresh[WARMUP:]


@pytest.fixture(scope="module")
def recording(tmp_path_factory):
    path = tmp_path_factory.mktemp("webcam") / "webcam.avi"
    rig = CameraRig.around("arduino_arm_3dof")
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 30.0, rig.camera.image_size, isColor=False)
    assert writer.isOpened(), "this OpenCV cannot write MJPG"
    with Arm("arduino_arm_3dof", URL) as arm:
        recorder = _Recorder(rig.virtual_camera(arm, seed=1), writer)
        session = CameraSession(arm, path.with_name("direct.csv"), recorder, rig, frames=FRAMES)
        session.run(PLAN)
        session.log.close()
    writer.release()
    return path, recorder.truth, rig


def _replay(recording, log, **source):
    """Measure the plan again on the virtual arm, the frames coming from the video; returns the open source."""
    path, truth, rig = recording
    video = VideoSource(path, **source)
    with Arm("arduino_arm_3dof", URL) as arm:
        session = CameraSession(arm, log, video, rig, frames=FRAMES)
        df = session.run(PLAN)
        session.log.close()
    return df, video


def _ratio(df, truth):
    true = np.array([truth[p]["xyz".index(a)] * 1e3 for p, a in zip(df.pose_id, df.quantity)])
    return np.abs(df.value.to_numpy() - true) / df.resolution.to_numpy()


def test_a_camera_session_through_video_capture_agrees_with_the_truth(recording, tmp_path):
    df, video = _replay(recording, tmp_path / "webcam.csv", stale=STALE, warmup=WARMUP)
    assert video.capture.getBackendName() == "FFMPEG" and video.dropped == 0
    assert len(df) == len(PLAN) * FRAMES * 3 and set(df.instrument) == {"camera"}
    ratio = _ratio(load_measurements(tmp_path / "webcam.csv"), recording[1])
    # the readings' k = 2 uncertainties hold through MJPG compression (measured: |error| <= 0.2 U)
    assert np.all(ratio <= 1.0), np.sort(ratio)[-5:]
    # the stream is used up: the next capture says so instead of returning old frames
    with pytest.raises(DeviceError, match="pose 'after_the_plan'.*end of the stream") as info:
        video.frames("after_the_plan", 1)
    assert isinstance(info.value, LabkitError)
    video.close()


def test_without_dropping_the_queue_the_readings_show_the_previous_pose(recording, tmp_path):
    df, video = _replay(recording, tmp_path / "stale.csv", stale=0, warmup=0)
    video.close()
    ratio = _ratio(df, recording[1])
    first = df.note.str.endswith(f"frame 1/{FRAMES}").to_numpy()
    # the first frame after each move is one the webcam queued before it: centimetres off
    assert np.median(ratio[first]) > 20


def test_end_of_stream_inside_a_pose_is_a_clear_error(recording):
    video = VideoSource(recording[0], stale=STALE, warmup=WARMUP)
    total = int(video.capture.get(cv2.CAP_PROP_FRAME_COUNT))
    assert total == len(PLAN) * (STALE + WARMUP + FRAMES)
    video.frames("p0", total - STALE - WARMUP - 1)  # one frame left
    video.stale = video.warmup = 0
    with pytest.raises(DeviceError, match=r"pose 'p1': expected 2 frames from .*, got 1 .*end of the stream"):
        video.frames("p1", 2)
    video.close()
    with pytest.raises(DeviceError, match="it was closed"):
        video.frames("p2", 1)


def test_truncated_video_and_wrong_sizes_are_clear_errors(recording, tmp_path):
    path, _, rig = recording
    cut = tmp_path / "cut.avi"
    data = path.read_bytes()
    cut.write_bytes(data[: len(data) // 2])  # a recording that stopped half way
    with VideoSource(cut, stale=STALE, warmup=WARMUP) as video:
        with pytest.raises(DeviceError, match="end of the stream or the camera dropped out"):
            for pose in PLAN:
                video.frames(pose.pose_id, FRAMES)
    with pytest.raises(DeviceError, match=r"expected 640x480 frames from .*, it delivers 1280x960"):
        VideoSource(path, width=640, height=480)
    with pytest.raises(DeviceError, match="could not open it"):
        VideoSource(tmp_path / "no_such_camera.avi")
    small = dataclasses.replace(rig.camera, image_size=(640, 480))
    with Arm("arduino_arm_3dof", URL) as arm, VideoSource(path) as video:
        session = CameraSession(arm, tmp_path / "x.csv", video, rig, camera=small, frames=1)
        with pytest.raises(VisionError, match=r"pose 'j1_20': expected 640x480 frames .*, got 1280x960"):
            session.measure(PLAN[0])


def test_default_queue_length_for_live_devices_and_files(recording):
    with VideoSource(recording[0]) as video:  # a file: nothing queued
        assert (video.stale, video.warmup) == (0, 3)
