"""Keyframe interpolation and uniform resampling of joint animations (quaternions xyzw)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from simcore.errors import InvalidInput
from simcore.motion.types import JointAnimation


def normalize_quats(q: np.ndarray) -> np.ndarray:
    """(..., 4) unit quaternions; zero-length inputs become identity."""
    q = np.asarray(q, dtype=np.float64)
    n = np.linalg.norm(q, axis=-1, keepdims=True)
    ident = np.zeros_like(q)
    ident[..., 3] = 1.0
    return np.where(n > 1e-12, q / np.maximum(n, 1e-12), ident)


def slerp(q0: np.ndarray, q1: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Shortest-path spherical interpolation.

    q0, q1: (..., 4) unit quaternions xyzw; u: (...,) fractions in [0, 1]. Returns (..., 4) unit quaternions.
    """
    q0, q1 = normalize_quats(q0), normalize_quats(q1)
    u = np.asarray(u, dtype=np.float64)[..., None]
    dot = np.sum(q0 * q1, axis=-1, keepdims=True)
    q1 = np.where(dot < 0, -q1, q1)  # take the short way round
    dot = np.abs(dot)
    theta = np.arccos(np.clip(dot, -1.0, 1.0))
    sin = np.sin(theta)
    near = sin < 1e-6  # nearly equal: lerp is exact enough and avoids 0/0
    safe = np.where(near, 1.0, sin)
    w0 = np.where(near, 1.0 - u, np.sin((1.0 - u) * theta) / safe)
    w1 = np.where(near, u, np.sin(u * theta) / safe)
    return normalize_quats(w0 * q0 + w1 * q1)


def key_segments(key_times: np.ndarray, times: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Segment index k (key k .. k+1) and fraction u in [0, 1] of each sample time; clamps outside the keys.

    key_times: (K,) increasing; times: (T,). Returns (T,) int64 and (T,) float64.
    """
    key_times = np.asarray(key_times, dtype=np.float64)
    if len(key_times) == 1:
        return np.zeros(len(times), np.int64), np.zeros(len(times))
    k = np.clip(np.searchsorted(key_times, times, side="right") - 1, 0, len(key_times) - 2)
    span = key_times[k + 1] - key_times[k]
    u = np.clip((times - key_times[k]) / np.where(span > 0, span, 1.0), 0.0, 1.0)
    return k, u


def sample_track(
    key_times: np.ndarray, values: np.ndarray, times: np.ndarray, interpolation: str = "LINEAR", rotation: bool = False
) -> np.ndarray:
    """Sample one keyframed track (glTF sampler semantics).

    key_times: (K,) seconds, increasing. values: (K, W) for LINEAR/STEP, (3K, W) [in-tangent, value, out-tangent]
    triplets for CUBICSPLINE. times: (T,) seconds. rotation: W == 4 quaternions (slerp, renormalised).
    Returns (T, W) float64.
    """
    key_times = np.asarray(key_times, dtype=np.float64).reshape(-1)
    values = np.asarray(values, dtype=np.float64)
    times = np.asarray(times, dtype=np.float64)
    if len(key_times) == 0:
        raise InvalidInput("animation sampler has no keyframes", code="invalid_gltf", field="motion")
    if np.any(np.diff(key_times) < 0):
        raise InvalidInput("animation sampler times are not increasing", code="invalid_gltf", field="motion")
    cubic = interpolation == "CUBICSPLINE"
    if len(values) != (3 if cubic else 1) * len(key_times):
        raise InvalidInput("animation sampler output count does not match its input", code="invalid_gltf", field="motion")
    k, u = key_segments(key_times, times)
    if cubic:
        trip = values.reshape(len(key_times), 3, -1)
        v = trip[:, 1]
        if len(key_times) == 1:
            out = np.repeat(v[:1], len(times), axis=0)
        else:
            dt = (key_times[k + 1] - key_times[k])[:, None]
            s, s2, s3 = u[:, None], u[:, None] ** 2, u[:, None] ** 3
            out = ((2 * s3 - 3 * s2 + 1) * v[k] + (s3 - 2 * s2 + s) * dt * trip[k, 2]
                   + (-2 * s3 + 3 * s2) * v[k + 1] + (s3 - s2) * dt * trip[k + 1, 0])
        # Before the first / after the last key, glTF holds the end values.
        out[times <= key_times[0]] = v[0]
        out[times >= key_times[-1]] = v[-1]
        return normalize_quats(out) if rotation else out
    if interpolation == "STEP" or len(key_times) == 1:
        idx = np.where(times >= key_times[-1], len(key_times) - 1, k)
        if len(key_times) > 1:
            idx = np.where(u >= 1.0, np.minimum(k + 1, len(key_times) - 1), idx)
        out = values[idx]
        return normalize_quats(out) if rotation else out.copy()
    if interpolation != "LINEAR":
        raise InvalidInput(f"unknown interpolation {interpolation!r}", code="invalid_gltf", field="motion")
    if rotation:
        return slerp(values[k], values[k + 1], u)
    return values[k] + u[:, None] * (values[k + 1] - values[k])


def whole_rate(fps: float) -> float:
    """The nearest whole number of frames per second (at least 1): USD time codes and FBX frames count whole
    frames per second, and a file's 120.00048 (a BVH frame time of 0.0083333 s) is 120."""
    return float(max(1, round(fps)))


def resample(anim: JointAnimation, fps: float | None = None, start: float | None = None, end: float | None = None) -> JointAnimation:
    """Cut to [start, end] seconds and resample at `fps` (default: the clip's own rate), rounded to a whole
    rate; slerp rotations. A clip within 0.1 % of that rate (a rounded frame time) keeps its frames.

    Raises InvalidInput(field="motion.start") when the range holds no time.
    """
    fps = whole_rate(fps or anim.fps)
    if fps != anim.fps and abs(fps - anim.fps) <= 1e-3 * fps:
        anim = replace(anim, fps=fps)
    t0 = 0.0 if start is None else float(start)
    t1 = anim.duration if end is None else min(float(end), anim.duration)
    if t0 > t1 or t0 > anim.duration:
        raise InvalidInput(
            f"motion time range [{t0:g}, {t1:g}] s is outside the clip (0 to {anim.duration:.3f} s)",
            code="invalid_time_range", field="motion.start",
        )
    if fps == anim.fps and start in (None, 0, 0.0) and end is None:
        return anim
    n = int(np.floor((t1 - t0) * fps + 1e-6)) + 1
    times = t0 + np.arange(n) / fps
    src_times = np.arange(anim.num_frames) / anim.fps
    k, u = key_segments(src_times, times)
    k1 = np.minimum(k + 1, anim.num_frames - 1)
    rot = slerp(anim.rotations[k], anim.rotations[k1], np.broadcast_to(u[:, None], (n, len(anim.joint_names))))
    tr = anim.translations[k] + u[:, None, None] * (anim.translations[k1] - anim.translations[k])
    return JointAnimation(list(anim.joint_names), fps, rot, tr, anim.name, anim.loop)
