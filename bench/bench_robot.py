"""The robot polishing cell (issue 26, paper 004) on NASA Rotor 37: the free angle about the
tool axis resolved with the KR 120 R2700-2 preset, head on the flange axis vs at 45°; the
closed-form inverse kinematics' speed; every program dialect written, read back and turned
through forward kinematics. Prints figures (no assertion).

    python bench/bench_robot.py [--feed 600] [--samples 36]
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from blisk_cam.core.robot import kinematics as K  # noqa: E402
from blisk_cam.core.robot.description import load_robot  # noqa: E402
from blisk_cam.core.robot.free_angle import FreeAngleOptions, plan_robot  # noqa: E402
from blisk_cam.core.robot.programs import DIALECTS, robot_program  # noqa: E402
from blisk_cam.core.robot.readers import decode_joints, read_program  # noqa: E402
from tests.support.nc import rotor37_path  # noqa: E402


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--feed", type=float, default=600.0)
    ap.add_argument("--samples", type=int, default=36)
    args = ap.parse_args()
    t = time.perf_counter()
    path = rotor37_path()
    print(f"Rotor 37 path: {len(path.program)} program poses, {len(path.curves)} passes "
          f"({time.perf_counter() - t:.1f} s)")

    robot = load_robot("kr120-r2700")
    rng = np.random.default_rng(0)
    q = rng.uniform(robot.limits[:, 0], robot.limits[:, 1], (100_000, 6))
    T = K.flange_pose(robot, q)
    t = time.perf_counter()
    Q, ok = K.inverse(robot, T)
    dt = time.perf_counter() - t
    err = np.abs(K.flange_pose(robot, Q) - T[:, None]).max(axis=(2, 3))[ok].max()
    print(f"IK: {len(T)} poses × 8 configurations in {dt:.2f} s ({len(T) / dt:,.0f} poses/s); "
          f"max |FK(IK(T)) − T| {err:.1e}")

    opt = FreeAngleOptions(feed=args.feed, samples=args.samples)
    for name in ("kr120-r2700", "kr120-r2700-angled"):
        robot = load_robot(name)
        t = time.perf_counter()
        plan = plan_robot(robot, path, opt)
        dt = time.perf_counter() - t
        head = math.degrees(robot.head_angle)
        if plan.feasible:
            st = plan.stats
            print(f"{name} (head {head:.0f}°): feasible in {dt:.1f} s; min wrist margin "
                  f"{st['min_wrist_deg']:.2f}°, min limit margin {st['min_limit_margin_deg']:.2f}°,"
                  f" max joint step {st['max_joint_step_deg']:.2f}°, max joint speed "
                  f"{100 * st['max_speed_ratio']:.0f}% at {args.feed:g} mm/min")
            for d in DIALECTS:
                t = time.perf_counter()
                prog = robot_program(plan, d, path=path)
                read = read_program(d, prog.files, prog.main)
                qd = decode_joints(robot, d, read)
                F = robot.pose_of(K.flange_pose(robot, qd))
                tip = np.abs(F[:, :3, 3] - path.program.tip).max()
                ax = np.arccos(np.clip(np.einsum("ij,ij->i", -F[:, :3, 2], path.program.axis),
                                       -1, 1)).max()
                lines = sum(len(x.splitlines()) for x in prog.files.values())
                print(f"  {d:9s} {len(prog.files)} files, {lines} lines; read back: tip "
                      f"{tip * 1000:.3f} µm, axis {ax:.1e} rad, joints "
                      f"{np.abs(qd - prog.joints).max():.1e} rad ({time.perf_counter() - t:.1f} s)")
        else:
            n = sum(b.last - b.first + 1 for b in plan.infeasible)
            reasons = sorted({b.reason for b in plan.infeasible})
            print(f"{name} (head {head:.0f}°): {len(plan.infeasible)} infeasible ranges, {n} "
                  f"poses ({', '.join(reasons)}) in {dt:.1f} s")


if __name__ == "__main__":
    main()
