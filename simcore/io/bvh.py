"""Strict BVH (Biovision hierarchy) reader: skeleton + per-frame local rotations and translations.

Conventions: a joint's CHANNELS list its rotations in the order they compose, R = R_first · R_second ·
R_third (intrinsic; scipy's upper-case Euler sequence), applied to column vectors in the parent frame.
Position channels replace the joint's OFFSET (as three.js and most exporters read them). `End Site`
blocks become leaf joints named `<parent>_End` without channels (they carry bone directions). The
file is assumed +Y up; units are guessed from the rest skeleton's height (metres, centimetres,
millimetres, inches or CMU units, whichever gives a height nearest a 1.7 m person) unless `unit_scale` is given.
Every malformed construct raises InvalidInput(code="invalid_bvh", field="motion") naming the line.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.spatial.transform import Rotation

from simcore.errors import InvalidInput, LimitExceeded
from simcore.motion.types import JointAnimation, MotionClip
from simcore.skeleton.types import Skeleton

MAX_BYTES = 64 * 1024 * 1024
MAX_JOINTS = 512
MAX_FRAMES = 200_000
MAX_VALUES = 40_000_000  # frames × channels
MAX_DEPTH = 128
CHANNEL_NAMES = ("Xposition", "Yposition", "Zposition", "Xrotation", "Yrotation", "Zrotation")
# Candidate file units → metres, and the height they are judged against.
# "cmu": the CMU mocap length unit (1/0.45 inch), used by the widespread cgspeed BVH conversions.
UNIT_SCALES = {"m": 1.0, "cm": 0.01, "mm": 0.001, "in": 0.0254, "cmu": 0.0254 / 0.45}
TYPICAL_HEIGHT_M = 1.7


def _fail(message: str, line: int | None = None) -> InvalidInput:
    where = f"line {line}: " if line is not None else ""
    return InvalidInput(f"BVH {where}{message}", code="invalid_bvh", field="motion")


class _Tokens:
    """Whitespace tokens of the hierarchy section with their 1-based line numbers."""

    def __init__(self, lines: list[str], first_line: int):
        self.items: list[tuple[str, int]] = []
        for k, text in enumerate(lines):
            self.items.extend((tok, first_line + k) for tok in text.split())
        self.pos = 0

    def next(self, what: str) -> tuple[str, int]:
        if self.pos >= len(self.items):
            last = self.items[-1][1] if self.items else 1
            raise _fail(f"unexpected end of hierarchy, expected {what}", last)
        tok = self.items[self.pos]
        self.pos += 1
        return tok

    def expect(self, word: str) -> int:
        tok, line = self.next(repr(word))
        if tok != word:
            raise _fail(f"expected {word!r}, found {tok!r}", line)
        return line

    def number(self, what: str) -> float:
        tok, line = self.next(what)
        try:
            value = float(tok)
        except ValueError:
            raise _fail(f"expected a number for {what}, found {tok!r}", line) from None
        if not math.isfinite(value):
            raise _fail(f"{what} is not finite", line)
        return value


def _parse_joint(tokens: _Tokens, keyword: str, parent: int, depth: int, out: dict[str, list]) -> None:
    """Read one `NAME { OFFSET x y z [CHANNELS n ...] (JOINT ... | End Site ...)* }` block, recursively."""
    names = out["names"]
    if keyword == "End":
        tokens.expect("Site")
        name = f"{names[parent]}_End"
    else:
        name, name_line = tokens.next("a joint name")
        if name in ("{", "}"):
            raise _fail(f"{keyword} has no name", name_line)
    if len(names) >= MAX_JOINTS:
        raise LimitExceeded(f"BVH has more than {MAX_JOINTS} joints", code="too_many_joints", field="motion")
    brace_line = tokens.expect("{")
    if depth > MAX_DEPTH:
        raise _fail(f"hierarchy deeper than {MAX_DEPTH} joints", brace_line)
    tokens.expect("OFFSET")
    offset = np.array([tokens.number("OFFSET x"), tokens.number("OFFSET y"), tokens.number("OFFSET z")])
    chans: list[str] = []
    tok, line = tokens.next("CHANNELS, JOINT, End Site or }")
    if tok == "CHANNELS":
        if keyword == "End":
            raise _fail("an End Site cannot have CHANNELS", line)
        count_tok, count_line = tokens.next("channel count")
        if not count_tok.isdigit() or not 1 <= int(count_tok) <= 6:
            raise _fail(f"channel count must be 1..6, found {count_tok!r}", count_line)
        for _ in range(int(count_tok)):
            ch, ch_line = tokens.next("a channel name")
            if ch not in CHANNEL_NAMES:
                raise _fail(f"unknown channel {ch!r} (expected one of {', '.join(CHANNEL_NAMES)})", ch_line)
            if ch in chans:
                raise _fail(f"channel {ch!r} repeated", ch_line)
            chans.append(ch)
        tok, line = tokens.next("JOINT, End Site or }")
    index = len(names)
    names.append(name)
    out["parents"].append(parent)
    out["offsets"].append(offset)
    out["channels"].append(chans)
    while tok != "}":
        if keyword == "End":
            raise _fail(f"an End Site cannot have children, found {tok!r}", line)
        if tok not in ("JOINT", "End"):
            raise _fail(f"expected JOINT, End Site or }}, found {tok!r}", line)
        _parse_joint(tokens, tok, index, depth + 1, out)
        tok, line = tokens.next("JOINT, End Site or }")


def _parse_hierarchy(tokens: _Tokens) -> dict[str, list]:
    """names, parents, offsets (3,) and channel lists of every joint, in file (depth-first) order."""
    tokens.expect("HIERARCHY")
    tok, line = tokens.next("ROOT")
    if tok != "ROOT":
        raise _fail(f"expected ROOT, found {tok!r}", line)
    out: dict[str, list] = {"names": [], "parents": [], "offsets": [], "channels": []}
    _parse_joint(tokens, "ROOT", -1, 1, out)
    if tokens.pos != len(tokens.items):
        tok, line = tokens.items[tokens.pos]
        raise _fail(f"unexpected {tok!r} after the root joint (only one ROOT is supported)", line)
    if len(set(out["names"])) != len(out["names"]):
        dup = next(n for n in out["names"] if out["names"].count(n) > 1)
        raise _fail(f"joint name {dup!r} is used twice")
    return out


def _header_value(line_text: str, key: str, line_no: int) -> float:
    head, _, value = line_text.partition(":")
    if head.strip().lower() != key.lower():
        raise _fail(f"expected '{key}:', found {line_text.strip()[:40]!r}", line_no)
    try:
        out = float(value)
    except ValueError:
        raise _fail(f"'{key}:' needs a number, found {value.strip()[:40]!r}", line_no) from None
    if not math.isfinite(out):
        raise _fail(f"'{key}:' is not finite", line_no)
    return out


def _parse_frames(lines: list[str], first_line: int, frames: int, width: int) -> np.ndarray:
    """(frames, width) float64 from the data lines; on any mismatch, find and name the bad line."""
    data_lines = [(k, ln) for k, ln in enumerate(lines) if ln.strip()]
    if len(data_lines) < frames:
        raise _fail(f"'Frames: {frames}' but only {len(data_lines)} frame lines follow", first_line + len(lines) - 1)
    data_lines = data_lines[:frames]  # exporters often add a trailing extra frame; read what is declared
    try:
        values = np.array(" ".join(ln for _, ln in data_lines).split(), dtype=np.float64)
        ok = values.size == frames * width and np.all(np.isfinite(values))
    except ValueError:
        ok = False
    if ok:
        return values.reshape(frames, width)
    for k, text in data_lines:  # slow path only to name the offending line
        parts = text.split()
        if len(parts) != width:
            raise _fail(f"frame has {len(parts)} values, the hierarchy declares {width} channels", first_line + k)
        try:
            row = np.array(parts, dtype=np.float64)
        except ValueError:
            bad = next(p for p in parts if not _is_float(p))
            raise _fail(f"frame value {bad!r} is not a number", first_line + k) from None
        if not np.all(np.isfinite(row)):
            raise _fail("frame value is not finite", first_line + k)
    raise _fail("frame data does not parse")


def _is_float(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def _world_rest(parents: list[int], offsets: np.ndarray) -> np.ndarray:
    out = np.zeros_like(offsets)
    for j, p in enumerate(parents):
        out[j] = offsets[j] + (out[p] if p >= 0 else 0.0)
    return out


def guess_unit_scale(rest_positions: np.ndarray) -> tuple[float, str]:
    """(scale to metres, unit name) whose scaled rest height (Y extent) is nearest a 1.7 m figure in log space."""
    height = float(np.ptp(rest_positions[:, 1])) or float(np.ptp(rest_positions, axis=0).max())
    if height <= 0:
        return 1.0, "m"
    unit = min(UNIT_SCALES, key=lambda u: abs(math.log(height * UNIT_SCALES[u] / TYPICAL_HEIGHT_M)))
    return UNIT_SCALES[unit], unit


def _local_rotations(values: np.ndarray, channels: list[list[str]], columns: list[list[int]]) -> np.ndarray:
    """(T, J, 4) xyzw local rotations; joints grouped by rotation order so scipy runs once per order."""
    t, j = len(values), len(channels)
    out = np.zeros((t, j, 4))
    out[..., 3] = 1.0
    groups: dict[str, list[int]] = {}
    for k, chans in enumerate(channels):
        order = "".join(c[0] for c in chans if c.endswith("rotation"))
        if order:
            groups.setdefault(order, []).append(k)
    for order, joints in groups.items():
        cols = np.array([[columns[k][i] for i, c in enumerate(channels[k]) if c.endswith("rotation")] for k in joints])
        angles = values[:, cols]  # (T, G, len(order)) degrees
        rot = Rotation.from_euler(order.upper(), angles.reshape(-1, len(order)), degrees=True)
        out[:, joints] = rot.as_quat().reshape(t, len(joints), 4)
    return out


def parse_bvh(data: bytes | str, unit_scale: float | None = None, name: str = "bvh") -> MotionClip:
    """Parse BVH text into a MotionClip (skeleton in metres, orientations None; local animation).

    data: file bytes (UTF-8/ASCII) or text. unit_scale: file units → metres; None guesses from height.
    Raises InvalidInput(code="invalid_bvh") naming the line, LimitExceeded over the caps.
    """
    if isinstance(data, bytes):
        if len(data) > MAX_BYTES:
            raise LimitExceeded(f"BVH is {len(data)} bytes, over the {MAX_BYTES}-byte cap", code="file_too_large", field="motion")
        try:
            data = data.decode("utf-8-sig")
        except UnicodeDecodeError as exc:
            raise _fail(f"file is not UTF-8/ASCII text (byte {exc.start})") from None
    elif len(data) > MAX_BYTES:
        raise LimitExceeded(f"BVH is over the {MAX_BYTES}-byte cap", code="file_too_large", field="motion")
    lines = data.splitlines()
    motion_at = next((k for k, ln in enumerate(lines) if ln.strip() == "MOTION"), None)
    if motion_at is None:
        raise _fail("no MOTION section", len(lines) or 1)
    hierarchy = _parse_hierarchy(_Tokens(lines[:motion_at], 1))
    frames_value = _header_value(lines[motion_at + 1] if motion_at + 1 < len(lines) else "", "Frames", motion_at + 2)
    frame_time = _header_value(lines[motion_at + 2] if motion_at + 2 < len(lines) else "", "Frame Time", motion_at + 3)
    if frames_value != int(frames_value) or frames_value < 1:
        raise _fail(f"'Frames:' must be a positive integer, found {frames_value:g}", motion_at + 2)
    frames = int(frames_value)
    if frames > MAX_FRAMES:
        raise LimitExceeded(f"BVH has {frames} frames, over the {MAX_FRAMES}-frame cap", code="too_many_frames", field="motion")
    if not 1e-4 <= frame_time <= 10.0:
        raise _fail(f"'Frame Time:' {frame_time:g} s is outside 0.0001..10 s", motion_at + 3)
    channels = hierarchy["channels"]
    widths = np.cumsum([0] + [len(c) for c in channels])
    width = int(widths[-1])
    if width == 0:
        raise _fail("the hierarchy declares no CHANNELS", motion_at)
    if frames * width > MAX_VALUES:
        raise LimitExceeded(f"BVH holds {frames * width} values, over the {MAX_VALUES} cap", code="too_many_frames", field="motion")
    values = _parse_frames(lines[motion_at + 3:], motion_at + 4, frames, width)
    columns = [list(range(widths[k], widths[k + 1])) for k in range(len(channels))]

    parents = hierarchy["parents"]
    offsets = np.array(hierarchy["offsets"], dtype=np.float64)
    rest = _world_rest(parents, offsets)
    unit = "option"
    if unit_scale is None:
        unit_scale, unit = guess_unit_scale(rest)
    j = len(parents)
    translations = np.broadcast_to(offsets, (frames, j, 3)).copy()
    for k, chans in enumerate(channels):
        for i, c in enumerate(chans):
            if c.endswith("position"):
                translations[:, k, "XYZ".index(c[0])] = values[:, columns[k][i]]
    rotations = _local_rotations(values, channels, columns)
    skeleton = Skeleton(rest * unit_scale, np.asarray(parents), hierarchy["names"])
    anim = JointAnimation(hierarchy["names"], 1.0 / frame_time, rotations, translations * unit_scale, name)
    return MotionClip(skeleton, anim, rest_is_standing=False, source_format="bvh", unit_scale=float(unit_scale), unit=unit)
