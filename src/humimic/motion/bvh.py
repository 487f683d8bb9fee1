"""BVH motion capture: parser with line-numbered errors, and forward kinematics.

Format (Biovision): ``HIERARCHY``, one ``ROOT name { OFFSET x y z  CHANNELS n c1 .. cn
(JOINT name {...} | End Site { OFFSET x y z })* }``, then ``MOTION``, ``Frames: F``,
``Frame Time: dt`` and F lines of channel values (joints in hierarchy order, each joint's
channels in its own order). Channels are ``X|Y|Z`` + ``position|rotation``, in any order.

Conventions (the common reading, e.g. Blender's and the CMU conversions'): rotation channels
are angles in degrees composed left to right in the order listed, ``R = R_c1 R_c2 R_c3``
(intrinsic); a joint's translation from its parent is ``OFFSET`` plus its position channels;
``global = parent_global * (translation, R)``. Lengths stay in the file's unit.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from humimic.errors import InputError
from humimic.motion import quat

CHANNELS = {f"{a}{k}" for a in "XYZ" for k in ("position", "rotation")}
_ROT = {"X": quat.rot_x, "Y": quat.rot_y, "Z": quat.rot_z}
#: Frame times accepted (s): motion capture runs at 2 kHz at most (playback samples the clip at
#: its frame rate, so a header claiming 1 ns frames would mean billions of samples).
FRAME_TIME_S = (5e-4, 10.0)


class BVHError(InputError, ValueError):
    """A malformed (or unreadable) BVH file; the message names the file, the line and what was
    expected. An :class:`~humimic.errors.InputError`: the CLI prints it and exits 2."""


@dataclass(frozen=True)
class BVHJoint:
    name: str
    parent: int
    """Index of the parent joint, -1 for the root."""
    offset: np.ndarray
    channels: tuple[str, ...]
    channel_start: int
    """Column of this joint's first channel in :attr:`BVH.motion`."""
    end_site: np.ndarray | None = None
    """Offset of an ``End Site`` child, if any."""


@dataclass(frozen=True)
class BVH:
    joints: tuple[BVHJoint, ...]
    frame_time: float
    motion: np.ndarray
    """(F, C) channel values per frame."""
    source: str = "<string>"

    @property
    def n_frames(self) -> int:
        return len(self.motion)

    @property
    def fps(self) -> float:
        return 1.0 / self.frame_time

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(j.name for j in self.joints)

    def index(self, name: str) -> int:
        try:
            return self.names.index(name)
        except ValueError:
            raise BVHError(f"{self.source}: no joint {name!r} (joints: "
                           f"{', '.join(self.names)})") from None


class _Tokens:
    """Whitespace tokens with their 1-based line numbers; errors name file and line."""

    def __init__(self, lines: list[str], source: str, stop: str):
        self.source = source
        self.items: list[tuple[str, int]] = []
        self.last_line = len(lines)
        for n, line in enumerate(lines, 1):
            words = line.split()
            self.items.extend((w, n) for w in words)
            if words and words[0] == stop:
                break
        self.i = 0

    def error(self, line: int, msg: str) -> BVHError:
        return BVHError(f"{self.source} line {line}: {msg}")

    def peek(self) -> tuple[str, int]:
        if self.i >= len(self.items):
            return "", self.last_line
        return self.items[self.i]

    def next(self, expected: str) -> tuple[str, int]:
        tok, line = self.peek()
        if not tok:
            raise self.error(line, f"unexpected end of file, expected {expected}")
        self.i += 1
        return tok, line

    def expect(self, word: str) -> int:
        tok, line = self.next(repr(word))
        if tok != word:
            raise self.error(line, f"expected {word!r}, got {tok!r}")
        return line

    def numbers(self, count: int, after: str) -> np.ndarray:
        out = []
        for _ in range(count):
            tok, line = self.next(f"{count} numbers after {after}")
            if not _is_finite_number(tok):
                raise self.error(line, f"expected {count} numbers after {after}, got {tok!r}")
            out.append(float(tok))
        return np.array(out)


def _parse_joint(tk: _Tokens, joints: list[BVHJoint], parent: int, ncol: int) -> int:
    """Parse ``name { ... }`` after ROOT/JOINT; returns the updated channel count."""
    name, line = tk.next("a joint name")
    if name == "{":
        raise tk.error(line, "expected a joint name before '{'")
    tk.expect("{")
    tk.expect("OFFSET")
    offset = tk.numbers(3, "OFFSET")
    tok, line = tk.next("'CHANNELS'")
    if tok != "CHANNELS":
        raise tk.error(line, f"expected 'CHANNELS' after the OFFSET of {name}, got {tok!r}")
    count_tok, line = tk.next("the channel count")
    if not count_tok.isdecimal():
        raise tk.error(line, f"expected the number of channels after CHANNELS, got {count_tok!r}")
    channels = []
    for _ in range(int(count_tok)):
        ch, line = tk.next(f"{count_tok} channel names")
        if ch not in CHANNELS:
            raise tk.error(line, f"expected a channel name (X/Y/Z + position/rotation), "
                                 f"got {ch!r}")
        channels.append(ch)
    index = len(joints)
    joints.append(BVHJoint(name, parent, offset, tuple(channels), ncol))
    ncol += len(channels)
    while True:
        tok, line = tk.next("'JOINT', 'End Site' or '}'")
        if tok == "}":
            return ncol
        if tok == "JOINT":
            ncol = _parse_joint(tk, joints, index, ncol)
        elif tok == "End":
            tk.expect("Site")
            tk.expect("{")
            tk.expect("OFFSET")
            end = tk.numbers(3, "OFFSET")
            tk.expect("}")
            j = joints[index]
            joints[index] = BVHJoint(j.name, j.parent, j.offset, j.channels, j.channel_start, end)
        else:
            raise tk.error(line, f"expected 'JOINT', 'End Site' or '}}' in {name}, got {tok!r}")


def parse_bvh(text: str, source: str = "<string>") -> BVH:
    """Parse BVH text; ``source`` names the file in error messages."""
    lines = text.splitlines()
    tk = _Tokens(lines, source, stop="MOTION")
    tok, line = tk.next("'HIERARCHY'")
    if tok != "HIERARCHY":
        raise tk.error(line, f"expected 'HIERARCHY', got {tok!r}")
    tk.expect("ROOT")
    joints: list[BVHJoint] = []
    ncol = _parse_joint(tk, joints, -1, 0)
    tok, line = tk.next("'MOTION'")
    if tok != "MOTION":
        raise tk.error(line, f"expected 'MOTION' after the hierarchy, got {tok!r}")

    def header(i: int, label: str) -> tuple[str, int]:
        while i < len(lines) and not lines[i].strip():
            i += 1
        if i >= len(lines):
            raise tk.error(len(lines), f"unexpected end of file, expected '{label}'")
        text_i = lines[i].strip()
        if not text_i.startswith(label):
            raise tk.error(i + 1, f"expected '{label} <value>', got {text_i!r}")
        return text_i[len(label):].strip(), i

    value, i = header(line, "Frames:")
    if not value.isdecimal():
        raise tk.error(i + 1, f"expected a non-negative integer after 'Frames:', got {value!r}")
    n_frames = int(value)
    value, i = header(i + 1, "Frame Time:")
    frame_time = float(value) if _is_finite_number(value) else -1.0
    if not FRAME_TIME_S[0] <= frame_time <= FRAME_TIME_S[1]:
        raise tk.error(i + 1, f"expected a frame time of {FRAME_TIME_S[0]:g} to "
                              f"{FRAME_TIME_S[1]:g} s after 'Frame Time:', got {value!r}")

    # never more rows than the file has lines (a header may claim any number of frames)
    motion = np.empty((min(n_frames, len(lines) - i - 1), ncol))
    f = 0
    for k in range(i + 1, len(lines)):
        words = lines[k].split()
        if not words:
            continue
        if f >= n_frames:
            raise tk.error(k + 1, f"more frame lines than 'Frames: {n_frames}'")
        if len(words) != ncol:
            raise tk.error(k + 1, f"expected {ncol} channel values in frame {f}, "
                                  f"got {len(words)}")
        bad = next((w for w in words if not _is_finite_number(w)), None)
        if bad is not None:
            raise tk.error(k + 1, f"expected a number in frame {f}, got {bad!r}")
        motion[f] = np.array(words, dtype=float)
        f += 1
    if f != n_frames:
        raise tk.error(len(lines), f"expected {n_frames} frame lines ('Frames: {n_frames}'), "
                                   f"found {f}")
    return BVH(tuple(joints), frame_time, motion, source)


def _is_finite_number(w: str) -> bool:
    """Whether ``w`` reads as a finite float (not ``nan``, ``inf`` or text)."""
    try:
        return math.isfinite(float(w))
    except ValueError:
        return False


def load_bvh(path: str | Path) -> BVH:
    """Read and parse a BVH file (errors name the file as given)."""
    path = Path(path)
    try:
        raw = path.read_bytes()
    except OSError as e:
        raise BVHError(f"{path}: cannot read BVH file ({e.strerror})") from None
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as e:
        line = raw.count(b"\n", 0, e.start) + 1
        raise BVHError(f"{path.name} line {line}: not a text (UTF-8) BVH file: byte "
                       f"{raw[e.start]:#04x} at offset {e.start}") from None
    return parse_bvh(text, path.name)


def local_transforms(bvh: BVH, motion: np.ndarray | None = None
                     ) -> tuple[np.ndarray, np.ndarray]:
    """Per joint rotation (F, J, 3, 3) and translation from the parent (F, J, 3)."""
    motion = bvh.motion if motion is None else np.atleast_2d(motion)
    F, J = len(motion), len(bvh.joints)
    R = np.broadcast_to(np.eye(3), (F, J, 3, 3)).copy()
    t = np.empty((F, J, 3))
    for j, joint in enumerate(bvh.joints):
        t[:, j] = joint.offset
        for c, ch in enumerate(joint.channels):
            v = motion[:, joint.channel_start + c]
            axis = ch[0]
            if ch.endswith("position"):
                t[:, j, "XYZ".index(axis)] += v
            else:
                R[:, j] = R[:, j] @ _ROT[axis](np.radians(v))
    return R, t


def forward_kinematics(bvh: BVH, motion: np.ndarray | None = None
                       ) -> tuple[np.ndarray, np.ndarray]:
    """Global joint rotations (F, J, 3, 3) and positions (F, J, 3) in the file's frame/unit.

    ``motion`` (F, C) defaults to the file's frames; pass zeros for the rest pose.
    """
    R_loc, t_loc = local_transforms(bvh, motion)
    R, p = np.empty_like(R_loc), np.empty_like(t_loc)
    for j, joint in enumerate(bvh.joints):
        if joint.parent < 0:
            R[:, j], p[:, j] = R_loc[:, j], t_loc[:, j]
        else:
            Rp = R[:, joint.parent]
            R[:, j] = Rp @ R_loc[:, j]
            p[:, j] = p[:, joint.parent] + np.einsum("fij,fj->fi", Rp, t_loc[:, j])
    return R, p


def end_site_positions(bvh: BVH, R: np.ndarray, p: np.ndarray) -> dict[str, np.ndarray]:
    """Global End Site positions (F, 3), keyed by the name of the joint carrying them."""
    return {j.name: p[:, k] + np.einsum("fij,j->fi", R[:, k], j.end_site)
            for k, j in enumerate(bvh.joints) if j.end_site is not None}


def has_reference_frame(bvh: BVH, max_rate_deg: float = 2500.0, margin_deg: float = 10.0
                        ) -> bool:
    """Whether frame 0 is a reference pose rather than motion (as in the CMU conversions): some
    joint's rotation jumps from frame 0 to 1 by more than a human could turn in one frame
    (``max_rate_deg`` deg/s times the frame time, plus ``margin_deg``)."""
    if bvh.n_frames < 3:
        return False
    R, _ = local_transforms(bvh, bvh.motion[:2])
    cos = (np.einsum("jik,jik->j", R[0], R[1]) - 1.0) / 2.0
    jump = np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))
    return bool(np.max(jump) > max_rate_deg * bvh.frame_time + margin_deg)


def drop_first_frames(bvh: BVH, n: int) -> BVH:
    """The clip without its first ``n`` frames."""
    return BVH(bvh.joints, bvh.frame_time, bvh.motion[n:], bvh.source)


def rest_pose(bvh: BVH) -> tuple[np.ndarray, np.ndarray]:
    """Global rotations (J, 3, 3) and positions (J, 3) with every channel zero."""
    R, p = forward_kinematics(bvh, np.zeros((1, bvh.motion.shape[1])))
    return R[0], p[0]
