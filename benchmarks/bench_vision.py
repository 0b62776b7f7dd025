"""Detection + pose time per 1280x960 frame (labkit.vision.marker_poses), on one core.

Prints frames per second and the ratio to the 30 frames/s target. The frame is
rendered by the virtual camera: one 4 cm AprilTag 36h11 at 0.5 m, tilted 30 deg,
plus four reference tags, with noise and blur.

Run: ``PYTHONPATH=$PWD python benchmarks/bench_vision.py``
"""

import time

import cv2
import numpy as np

from labkit.vision import Camera, VirtualCamera, marker_poses

TARGET_FPS = 30.0


def _load():
    try:
        with open("/proc/loadavg") as f:
            return f.read().split()[0]
    except OSError:
        return "n/a"


def main(repeats=60):
    cv2.setNumThreads(1)
    cam = Camera.pinhole(1000.0, (1280, 960), distortion=[-0.08, 0.05, 0, 0, 0])
    vc = VirtualCamera(cam, seed=0)
    poses = {}
    for k, (x, y) in enumerate([(0.0, 0.0), (-0.2, -0.12), (0.2, -0.12), (0.2, 0.12), (-0.2, 0.12)]):
        T = np.eye(4)
        c, s = np.cos(np.radians(30)), np.sin(np.radians(30))
        T[:3, :3] = [[1, 0, 0], [0, -c, -s], [0, s, -c]]
        T[:3, 3] = [x, y, 0.5]
        poses[k] = T
    image = vc.render_markers(poses, size=0.04)
    marker_poses(image, cam, 0.04)  # warm up
    times, cpu = [], []
    for _ in range(repeats):
        t0, c0 = time.perf_counter(), time.process_time()
        found = marker_poses(image, cam, 0.04)
        times.append(time.perf_counter() - t0)
        cpu.append(time.process_time() - c0)
    # wall time (median: what a session sees; best: the least disturbed call) and CPU time (the
    # process's own time on its one core, what a shared, loaded machine does not inflate)
    print(f"load average: {_load()}")
    for label, dt in (("wall, median", float(np.median(times))), ("wall, best", min(times)),
                      ("CPU, median", float(np.median(cpu)))):
        fps = 1.0 / dt
        print(f"marker_poses, 1280x960, {len(found)} markers, 1 thread, {label} of {repeats}: {dt * 1e3:.1f} ms/frame "
              f"= {fps:.1f} frames/s; ratio to the {TARGET_FPS:.0f} frames/s target: {fps / TARGET_FPS:.2f}")


if __name__ == "__main__":
    main()
