"""Pinhole camera model shared by the renderer and every vision stage.

Conventions (used everywhere in humimic):

* Pixel coordinates ``(u, v)`` are OpenCV's: ``u`` to the right, ``v`` down, the *centre* of
  pixel ``(i, j)`` (column ``i``, row ``j``) at integer coordinates. The principal point of an
  undistorted MuJoCo camera is therefore ``((W-1)/2, (H-1)/2)``.
* Camera frames are OpenCV's: x right, y down, z forward (along the optical axis). MuJoCo
  cameras look along their -z with +y up; :data:`R_MJCAM_CV` converts (the one place).
* Distortion is radial, OpenCV's first two coefficients: ``x_d = x (1 + k1 r^2 + k2 r^4)`` on
  normalised coordinates, so ``cv2.projectPoints`` with ``dist=[k1, k2, 0, 0]`` agrees.
* Units: metres and radians; pixels for image coordinates.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from dataclasses import dataclass, field

import cv2
import numpy as np

#: Rotation from a MuJoCo camera frame (x right, y up, z back) to OpenCV's (x right, y down,
#: z forward): ``p_cv = R_MJCAM_CV @ p_mjcam``, ``R_world_cv = R_world_mjcam @ R_MJCAM_CV``.
R_MJCAM_CV = np.diag([1.0, -1.0, -1.0])


#: OpenCV's iterative undistortion run to convergence (our former 8-step fixed point left up
#: to 0.003 px at k1 = -0.05 in the wide camera's corners; this leaves 1e-8 px).
UNDISTORT_CRITERIA = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 50, 1e-14)


def fovy_from_hfov(hfov_rad: float, width: int, height: int) -> float:
    """MuJoCo's vertical ``fovy`` (rad) for a horizontal field of view at ``width x height``."""
    return 2.0 * math.atan(math.tan(hfov_rad / 2.0) * height / width)


#: Least slope ``d r_d / d r`` of the radial distortion accepted over an image: its inverse
#: (undistortion) then exists and its slope is at most 4, so it stays well conditioned.
MIN_DISTORTION_SLOPE = 0.25


def max_invertible_radius(k1: float, k2: float, min_slope: float = MIN_DISTORTION_SLOPE
                          ) -> float:
    """The largest distorted normalised radius ``r_d = r (1 + k1 r^2 + k2 r^4)`` reached while
    the distortion's slope ``1 + 3 k1 r^2 + 5 k2 r^4`` stays at least ``min_slope`` (``inf`` if
    it always does): every distorted point within it has one undistorted preimage."""
    # slope == min_slope  <=>  5 k2 u^2 + 3 k1 u + (1 - min_slope) = 0 with u = r^2
    roots = np.roots([5.0 * k2, 3.0 * k1, 1.0 - min_slope])  # leading zeros are trimmed
    u = [z.real for z in roots if abs(z.imag) <= 1e-12 * abs(z) and z.real > 0]
    if not u:
        return math.inf
    r2 = min(u)
    return math.sqrt(r2) * (1.0 + k1 * r2 + k2 * r2 * r2)


def corner_radius(hfov_rad: float, width: int, height: int) -> float:
    """Normalised radius of the image corner (pixel centre) of a camera with horizontal field of
    view ``hfov_rad`` at ``width x height`` (square pixels, principal point at the centre)."""
    intr = Intrinsics.from_fovy(fovy_from_hfov(hfov_rad, width, height), width, height)
    return math.hypot(intr.cx / intr.fx, intr.cy / intr.fy)


@dataclass(frozen=True)
class Intrinsics:
    """Pinhole intrinsics plus radial distortion, in pixels (OpenCV conventions)."""

    width: int
    height: int
    fx: float
    fy: float
    cx: float
    cy: float
    k1: float = 0.0
    k2: float = 0.0

    @classmethod
    def from_fovy(cls, fovy_rad: float, width: int, height: int, k1: float = 0.0,
                  k2: float = 0.0) -> Intrinsics:
        """Intrinsics of a MuJoCo camera with vertical field of view ``fovy_rad`` (square px)."""
        f = (height / 2.0) / math.tan(fovy_rad / 2.0)
        return cls(width, height, f, f, (width - 1) / 2.0, (height - 1) / 2.0, k1, k2)

    @property
    def K(self) -> np.ndarray:
        return np.array([[self.fx, 0.0, self.cx], [0.0, self.fy, self.cy], [0.0, 0.0, 1.0]])

    @property
    def dist(self) -> np.ndarray:
        """OpenCV distortion vector ``[k1, k2, p1, p2]``."""
        return np.array([self.k1, self.k2, 0.0, 0.0])

    @property
    def hfov(self) -> float:
        return 2.0 * math.atan((self.width / 2.0) / self.fx)

    @property
    def distorted(self) -> bool:
        return self.k1 != 0.0 or self.k2 != 0.0

    def distort(self, x, y) -> tuple[np.ndarray, np.ndarray]:
        """Undistorted normalised coordinates (arrays of any shape) to raw pixels ``(u, v)``."""
        if not self.distorted:  # s == 1 exactly
            return self.fx * x + self.cx, self.fy * y + self.cy
        r2 = x * x + y * y
        s = 1.0 + r2 * (self.k1 + self.k2 * r2)
        return self.fx * x * s + self.cx, self.fy * y * s + self.cy

    def project(self, p_cam: np.ndarray) -> np.ndarray:
        """Project camera-frame points ``(..., 3)`` (OpenCV axes, z forward) to pixels ``(..., 2)``.

        Points behind the camera (z <= 0) give NaN.
        """
        p = np.asarray(p_cam, dtype=float)
        if p.shape == (3,):     # one point: the same arithmetic on scalars (~5x less overhead)
            x, y, z = p.tolist()
            if not z > 0:
                return np.array([np.nan, np.nan])
            return np.array(self.distort(x / z, y / z))
        z = p[..., 2]
        with np.errstate(divide="ignore", invalid="ignore"):
            x = np.where(z > 0, p[..., 0] / z, np.nan)
            y = np.where(z > 0, p[..., 1] / z, np.nan)
        return np.stack(self.distort(x, y), axis=-1)

    def contains(self, uv: np.ndarray) -> np.ndarray:
        """Whether pixels ``(..., 2)`` lie on the image (its ``width x height`` pixels' squares,
        ``-0.5 <= u <= width - 0.5``, ``-0.5 <= v <= height - 0.5``); NaN (a point behind the
        camera, :meth:`project`) is not."""
        uv = np.asarray(uv, dtype=float)
        with np.errstate(invalid="ignore"):
            return ((uv[..., 0] >= -0.5) & (uv[..., 0] <= self.width - 0.5)
                    & (uv[..., 1] >= -0.5) & (uv[..., 1] <= self.height - 0.5))

    def undistort_normalized(self, uv: np.ndarray) -> np.ndarray:
        """Raw pixels ``(..., 2)`` to undistorted normalised coordinates ``(..., 2)``
        (``cv2.undistortPointsIter`` to :data:`UNDISTORT_CRITERIA`)."""
        uv = np.asarray(uv, dtype=float)
        if not self.distorted:
            return np.stack([(uv[..., 0] - self.cx) / self.fx,
                             (uv[..., 1] - self.cy) / self.fy], axis=-1)
        x = cv2.undistortPointsIter(uv.reshape(-1, 1, 2), self.K, self.dist, None, None,
                                    UNDISTORT_CRITERIA)
        return x.reshape(uv.shape)

    def undistort_jacobian(self, xy: np.ndarray) -> np.ndarray:
        """d(undistorted normalised point)/d(raw pixel) ``(..., 2, 2)`` at undistorted
        normalised points ``xy (..., 2)``: the inverse of the distortion's Jacobian."""
        xy = np.asarray(xy, dtype=float)
        x, y = xy[..., 0], xy[..., 1]
        r2 = x * x + y * y
        s = 1.0 + self.k1 * r2 + self.k2 * r2 * r2
        ds = 2.0 * (self.k1 + 2.0 * self.k2 * r2)
        a, b, d = s + ds * x * x, ds * x * y, s + ds * y * y  # d(distorted)/d(undistorted)
        det = a * d - b * b
        return np.stack([np.stack([d / (det * self.fx), -b / (det * self.fy)], -1),
                         np.stack([-b / (det * self.fx), a / (det * self.fy)], -1)], -2)

    def project_jacobian(self, p_cam: np.ndarray) -> np.ndarray:
        """``d project(p) / dp`` ``(..., 2, 3)`` for camera-frame points ``(..., 3)`` (z > 0)."""
        p = np.asarray(p_cam, dtype=float)
        iz = 1.0 / p[..., 2]
        x, y = p[..., 0] * iz, p[..., 1] * iz
        r2 = x * x + y * y
        s = 1.0 + self.k1 * r2 + self.k2 * r2 * r2
        ds = 2.0 * (self.k1 + 2.0 * self.k2 * r2)  # d s / d(x or y), divided by x or y
        # d(x s, y s)/d(x, y), then d(x, y)/dp = [[1/z, 0, -x/z], [0, 1/z, -y/z]]
        a, b, c = s + ds * x * x, ds * x * y, s + ds * y * y
        J = np.empty(p.shape[:-1] + (2, 3))
        J[..., 0, 0], J[..., 0, 1] = self.fx * a * iz, self.fx * b * iz
        J[..., 0, 2] = -self.fx * (a * x + b * y) * iz
        J[..., 1, 0], J[..., 1, 1] = self.fy * b * iz, self.fy * c * iz
        J[..., 1, 2] = -self.fy * (b * x + c * y) * iz
        return J

    def decimated(self, k: int) -> Intrinsics:
        """The camera of this one's image averaged over ``k x k`` pixel blocks (trimmed to whole
        blocks, ``cv2.resize`` with ``INTER_AREA`` to ``width // k x height // k``): block
        ``i`` spans pixels ``k i`` to ``k i + k - 1``, so a pixel coordinate ``u`` becomes
        ``(u + 0.5) / k - 0.5``."""
        k = int(k)
        return Intrinsics(self.width // k, self.height // k, self.fx / k, self.fy / k,
                          (self.cx + 0.5) / k - 0.5, (self.cy + 0.5) / k - 0.5, self.k1, self.k2)

    def pinhole(self) -> Intrinsics:
        """The same camera without distortion (what an undistorted image is taken with)."""
        return Intrinsics(self.width, self.height, self.fx, self.fy, self.cx, self.cy)

    def undistortion_maps(self) -> tuple[np.ndarray, np.ndarray]:
        """``cv2.remap`` maps that undistort this camera's image into :meth:`pinhole`'s: for
        each pixel of the undistorted image, where it lies in the distorted one (float32)."""
        u, v = np.meshgrid(np.arange(self.width, dtype=float), np.arange(self.height,
                                                                         dtype=float))
        u, v = self.distort((u - self.cx) / self.fx, (v - self.cy) / self.fy)
        return u.astype(np.float32), v.astype(np.float32)


@dataclass(frozen=True)
class CameraModel:
    """A calibrated camera at one instant: intrinsics and its pose.

    ``T_base_cam`` maps camera-frame (OpenCV axes) points into the robot base frame;
    ``T_world_cam`` into the world frame. Both are 4x4 homogeneous transforms.
    """

    name: str
    intrinsics: Intrinsics
    T_base_cam: np.ndarray
    T_world_cam: np.ndarray = field(default_factory=lambda: np.eye(4))

    @property
    def P_base(self) -> np.ndarray:
        """3x4 projection matrix from homogeneous base-frame points to pixels (no distortion)."""
        return self.intrinsics.K @ self.T_cam_base[:3, :]

    def with_intrinsics(self, intrinsics: Intrinsics) -> CameraModel:
        """The same camera at the same pose with other intrinsics (a crop, a decimation),
        keeping :attr:`T_cam_base` if it was computed."""
        cam = dataclasses.replace(self, intrinsics=intrinsics)
        if "T_cam_base" in self.__dict__:
            cam.__dict__["T_cam_base"] = self.__dict__["T_cam_base"]
        return cam

    @functools.cached_property
    def T_cam_base(self) -> np.ndarray:
        """``T_base_cam``'s inverse (read-only; computed once per camera model: the pose of
        a camera at one instant does not change)."""
        T = invert_transform(self.T_base_cam)
        T.setflags(write=False)
        return T

    def project_base(self, p_base: np.ndarray) -> np.ndarray:
        """Project base-frame points ``(..., 3)`` to pixels ``(..., 2)`` (with distortion)."""
        T_cam_base = self.T_cam_base
        p = np.asarray(p_base, dtype=float)
        p_cam = p @ T_cam_base[:3, :3].T + T_cam_base[:3, 3]
        return self.intrinsics.project(p_cam)

    def project_world(self, p_world: np.ndarray) -> np.ndarray:
        """Project world-frame points ``(..., 3)`` to pixels ``(..., 2)`` (with distortion)."""
        T_cam_world = invert_transform(self.T_world_cam)
        p = np.asarray(p_world, dtype=float)
        p_cam = p @ T_cam_world[:3, :3].T + T_cam_world[:3, 3]
        return self.intrinsics.project(p_cam)


def invert_transform(T: np.ndarray) -> np.ndarray:
    """Inverse of a 4x4 rigid transform."""
    R, p = T[:3, :3], T[:3, 3]
    out = np.eye(4)
    out[:3, :3] = R.T
    out[:3, 3] = -R.T @ p
    return out


def make_transform(R: np.ndarray, p: np.ndarray) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3] = R
    T[:3, 3] = p
    return T


@dataclass(frozen=True)
class CameraImage:
    """One rendered frame of one camera, sampled at simulated time ``t`` (s)."""

    t: float
    camera: CameraModel
    image: np.ndarray
    """H x W x 3, uint8, RGB, row 0 at the top."""
