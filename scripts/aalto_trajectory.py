"""The trajectory arithmetic of scripts/convert_aalto.py, on motion-capture positions (numpy
arrays: t in s, xy in m): glitch removal, keyframe selection and refinement, the chord error of
mm4mm's interpolation between keyframes, and the heading of travel with where it can be trusted.
"""
import math

import numpy as np


def position_glitches(t, xy, max_speed):
    """Mask of samples to drop: each is compared with the last kept one, and dropped when
    reaching it would take more than max_speed (a Vicon glitch, e.g. nexus/3 at 182.71 s)."""
    drop = np.zeros(len(t), dtype=bool)
    last = 0
    for i in range(1, len(t)):
        if np.hypot(*(xy[i] - xy[last])) > max_speed * (t[i] - t[last]):
            drop[i] = True
        else:
            last = i
    return drop


def select_keyframes(t, xy, distance_m, interval_s):
    """Indices of keyframe samples: first, every distance_m travelled or interval_s, last."""
    step = np.linalg.norm(np.diff(xy, axis=0), axis=1)
    chosen = [0]
    travelled = 0.0
    for i in range(1, len(t)):
        travelled += step[i - 1]
        if travelled >= distance_m or t[i] - t[chosen[-1]] >= interval_s:
            chosen.append(i)
            travelled = 0.0
    if chosen[-1] != len(t) - 1:
        chosen.append(len(t) - 1)
    return np.array(chosen)


def refine_keyframes(t, xy, kf, tolerance_m):
    """Adds keyframes until time interpolation between them places every sample within
    tolerance_m of its own position (split at the worst sample, recursively)."""
    if not tolerance_m > 0:
        return kf
    chosen = [int(kf[0])]
    for a, b in zip(kf[:-1], kf[1:]):
        pending, done = [(int(a), int(b))], []
        while pending:
            lo, hi = pending.pop()
            if hi - lo >= 2:
                w = (t[lo:hi + 1] - t[lo]) / (t[hi] - t[lo])
                placed = xy[lo] + w[:, None] * (xy[hi] - xy[lo])
                error = np.linalg.norm(placed - xy[lo:hi + 1], axis=1)
                worst = int(np.argmax(error))
                if error[worst] > tolerance_m:
                    pending += [(lo, lo + worst), (lo + worst, hi)]
                    continue
            done.append(hi)
        chosen += sorted(done)
    return np.array(chosen)


def interpolation_error(t, xy, kf):
    """Distances between each reading's Vicon position and where mm4mm places it (chords)."""
    placed = np.column_stack([np.interp(t, t[kf], xy[kf, k]) for k in range(2)])
    return np.linalg.norm(placed - xy, axis=1)


def travel_headings(t, xy, half_window_s=0.3, min_speed=0.05):
    """Heading of travel (rad) at every sample from the displacement over ±half_window_s; held
    from the last moving sample where the robot moves slower than min_speed (the first moving
    sample's heading before it)."""
    lo = np.searchsorted(t, t - half_window_s)
    hi = np.minimum(np.searchsorted(t, t + half_window_s, side="right") - 1, len(t) - 1)
    d = xy[hi] - xy[lo]
    dt = np.maximum(t[hi] - t[lo], 1e-9)
    moving = np.linalg.norm(d, axis=1) / dt >= min_speed
    if not moving.any():
        return np.zeros(len(t))
    heading = np.arctan2(d[:, 1], d[:, 0])
    last = np.where(moving, np.arange(len(t)), 0)
    np.maximum.accumulate(last, out=last)
    first = int(np.argmax(moving))
    last[:first] = first
    return heading[last]


def heading_reliable(t, xy, heading, half_window_s=0.3, min_speed=0.05, max_rate_dps=60.0):
    """Where the direction of travel says the heading: the robot moves at min_speed or more and
    its direction of travel turns slower than max_rate_dps. Standing or pivoting on the spot, the
    sensor (not on the pivot axis) moves sideways or not at all."""
    lo = np.searchsorted(t, t - half_window_s)
    hi = np.minimum(np.searchsorted(t, t + half_window_s, side="right") - 1, len(t) - 1)
    speed = np.linalg.norm(xy[hi] - xy[lo], axis=1) / np.maximum(t[hi] - t[lo], 1e-9)
    rate = np.abs(np.gradient(np.unwrap(heading), t)) if len(t) > 1 else np.zeros(len(t))
    return (speed >= min_speed) & (rate <= math.radians(max_rate_dps))
