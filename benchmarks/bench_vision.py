"""Detection + pose time per 1280x960 frame (labkit.vision.marker_poses), on one thread.

Prints frames per second as wall-clock time (what a measurement session waits) beside the
process's CPU time (what a loaded, shared machine does not inflate), and their ratio to the
30 frames/s target:

* one frame detected again and again (median and best call);
* a stream of distinct frames (fresh noise, the gripper tag moving), timed as a whole loop:
  frames / elapsed wall-clock time;
* the webcam path: the same stream as an MJPG video read through :class:`VideoSource`
  (``cv2.VideoCapture``: decoding included).

The frames are rendered by the virtual camera: one 4 cm AprilTag 36h11 at 0.5 m, tilted
30 deg, plus four reference tags, with noise and blur. OpenCV runs on one thread
(``cv2.setNumThreads(1)``).

Run: ``PYTHONPATH=$PWD python benchmarks/bench_vision.py``
"""

import tempfile
import time
from pathlib import Path

import cv2
import numpy as np

from labkit.vision import Camera, VideoSource, VirtualCamera, marker_poses

TARGET_FPS = 30.0


def _load():
    try:
        with open("/proc/loadavg") as f:
            return f.read().split()[0]
    except OSError:
        return "n/a"


def _scene(shift=0.0):
    poses = {}
    c, s = np.cos(np.radians(30)), np.sin(np.radians(30))
    for k, (x, y) in enumerate([(shift, 0.0), (-0.2, -0.12), (0.2, -0.12), (0.2, 0.12), (-0.2, 0.12)]):
        T = np.eye(4)
        T[:3, :3] = [[1, 0, 0], [0, -c, -s], [0, s, -c]]
        T[:3, 3] = [x, y, 0.5]
        poses[k] = T
    return poses


def _report(label, frames, wall, cpu, markers):
    print(f"{label}: {frames} frames of 1280x960, {markers} markers each, 1 thread")
    for kind, dt in (("wall clock", wall / frames), ("CPU time", cpu / frames)):
        fps = 1.0 / dt
        print(f"  {kind:>10}: {dt * 1e3:6.1f} ms/frame = {fps:6.1f} frames/s; ratio to the "
              f"{TARGET_FPS:.0f} frames/s target: {fps / TARGET_FPS:.2f}")
    print(f"  CPU / wall: {cpu / wall:.2f} (below 1: the process waited for a core)")


def main(repeats=60, stream=60):
    cv2.setNumThreads(1)
    cam = Camera.pinhole(1000.0, (1280, 960), distortion=[-0.08, 0.05, 0, 0, 0])
    vc = VirtualCamera(cam, seed=0)
    image = vc.render_markers(_scene(), size=0.04)
    marker_poses(image, cam, 0.04)  # warm up
    times, cpu = [], []
    for _ in range(repeats):
        t0, c0 = time.perf_counter(), time.process_time()
        found = marker_poses(image, cam, 0.04)
        times.append(time.perf_counter() - t0)
        cpu.append(time.process_time() - c0)
    print(f"load average: {_load()}  (cv2 threads: {cv2.getNumThreads()})")
    print(f"one frame, {repeats} calls: wall median {np.median(times) * 1e3:.1f} ms = {1 / np.median(times):.1f} frames/s, "
          f"wall best {min(times) * 1e3:.1f} ms = {1 / min(times):.1f} frames/s, CPU median "
          f"{np.median(cpu) * 1e3:.1f} ms = {1 / np.median(cpu):.1f} frames/s")

    frames = [vc.render_markers(_scene(0.05 * np.sin(k / 5)), size=0.04) for k in range(stream)]
    t0, c0 = time.perf_counter(), time.process_time()
    counts = [len(marker_poses(f, cam, 0.04)) for f in frames]
    _report("stream of distinct frames", stream, time.perf_counter() - t0, time.process_time() - c0, min(counts))

    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "stream.avi"
        writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 30.0, (1280, 960), isColor=False)
        for f in frames:
            writer.write(f)
        writer.release()
        with VideoSource(path, warmup=0) as video:
            t0, c0 = time.perf_counter(), time.process_time()
            counts = [len(marker_poses(f, cam, 0.04)) for f in video.frames("bench", stream)]
            _report("webcam path (MJPG decode in VideoSource + detection + pose)", stream,
                    time.perf_counter() - t0, time.process_time() - c0, min(counts))


if __name__ == "__main__":
    main()
