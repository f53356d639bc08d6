"""Type stubs of the native module (PyO3); the public API is re-exported by ``kinecal``."""

from os import PathLike
from typing import Any, Dict, List, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

_Path = Union[str, PathLike[str]]
_Array = npt.ArrayLike
_F64 = npt.NDArray[np.float64]
# One measurement set: q (n, N), xyz (n, 3), extra column names, extra (n, k) or None.
_Set = Tuple[_F64, _F64, List[str], Optional[_F64]]

class Robot:
    """A robot description (robot TOML): MDH rows (+ tilt), tool point, optional base pose,
    effects and couplings. Immutable; ``==`` compares the descriptions."""

    @staticmethod
    def from_file(path: _Path) -> "Robot":
        """Reads a robot TOML file; ``RefusedError`` names file, line and column."""
    @staticmethod
    def from_toml(text: str, origin: str = "<toml>") -> "Robot":
        """Parses robot TOML text; ``origin`` names it in error messages."""
    @staticmethod
    def from_mdh(
        rows: _Array,
        tool_xyz_mm: Sequence[float],
        base_xyz_mm: Optional[Sequence[float]] = None,
        base_rpy_deg: Optional[Sequence[float]] = None,
        limits_deg: Optional[_Array] = None,
        tool_rpy_deg: Optional[Sequence[float]] = None,
        name: str = "robot",
    ) -> "Robot":
        """A robot from MDH rows (N, 4) alpha_deg, a_mm, theta_deg, d_mm (or (N, 5) with
        beta_deg), the tool point, optionally the base pose and limits (N, 2) in degrees."""
    def to_toml(self) -> str:
        """The robot TOML text."""
    def save(self, path: _Path) -> None:
        """Writes the robot TOML file atomically."""
    @property
    def name(self) -> str: ...
    @property
    def joints(self) -> int:
        """Number of joints N."""
    @property
    def base_known(self) -> bool:
        """Whether the file gives ``[base]``."""
    @property
    def base(self) -> Optional[Tuple[List[float], List[float]]]:
        """``(xyz_mm, rpy_deg)`` or None."""
    @property
    def tool_xyz_mm(self) -> List[float]: ...
    @property
    def mdh(self) -> _F64:
        """(N, 5): alpha_deg, a_mm, theta_deg, d_mm, beta_deg."""
    @property
    def limits_deg(self) -> _F64:
        """(N, 2) joint limits, degrees."""
    def fk(self, q: _Array, angle_unit: str = "deg", temp_c: Optional[_Array] = None) -> _F64:
        """Measured point (n, 3) mm at joint readings q (n, N); (3,) for one pose (N,).
        ``temp_c`` (°C, one value or one per pose): where a thermal-expansion term is
        evaluated (without it: its reference temperature, with a ``DataWarning``)."""
    def jacobian(
        self,
        q: _Array,
        params: Union[str, Sequence[str], None] = None,
        angle_unit: str = "deg",
        temp_c: Optional[_Array] = None,
    ) -> Tuple[_F64, List[str]]:
        """Identification Jacobian (n, 3, P) (mm per mm / per rad) and the parameter names."""
    def parameter_names(self) -> List[str]:
        """Parameters ``identify`` estimates for this robot (jacobian's default columns)."""

def read_csv(
    path: _Path, joints: Optional[int] = None
) -> Tuple[_F64, _F64, List[str], _F64]: ...
def write_csv(
    path: _Path,
    q: _F64,
    xyz: _F64,
    extra_names: List[str] = ...,
    extra: Optional[_F64] = None,
) -> None: ...
def identify(
    robot: Robot, data: _Set, validate: Optional[_Set], options: Dict[str, Any]
) -> Tuple[str, str, bool]: ...
def check(robot: Robot, data: _Set, options: Dict[str, Any]) -> Tuple[str, bool]: ...
def diagnose(
    robot: Robot, data: _Set, validate: Optional[_Set], options: Dict[str, Any]
) -> Tuple[str, Optional[str], bool, str]: ...
def compensate(
    model: Robot, targets: _Set, options: Dict[str, Any]
) -> Tuple[str, bool, _F64, List[str], _F64, _F64]: ...
def frames(robot: Robot, sweeps: _Set, options: Dict[str, Any]) -> Tuple[str, str]: ...
def plan(robot: Robot, scene: Optional[_Path], options: Dict[str, Any]) -> Tuple[str, _F64]: ...
def simulate(
    robot: Robot, options: Dict[str, Any]
) -> Tuple[str, Tuple[_F64, _F64, List[str], _F64], str]: ...
def compensate_cartesian(
    model: Robot,
    nominal: Robot,
    seeds: _Array,
    targets: _Array,
    angle_unit: str = "deg",
    temp_c: Optional[_Array] = None,
) -> Tuple[_F64, List[str]]: ...
def unreached_error(failed: int, targets: int, cartesian: bool = False) -> Optional[str]: ...
