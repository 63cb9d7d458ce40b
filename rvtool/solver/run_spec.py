"""Solver settings as data, recorded in every results.json."""
from dataclasses import asdict, dataclass

from ..errors import RvtoolInputError
from ..validation import check_choice, check_positive, check_range

NEWTON_MODES = ("full", "per_step", "modified")
FLOAT32_REL_TOL_FLOOR = 1e-6
DENSE_MAX_COORDINATES = 30  # measured: EXUdense LU is 5x slower than EigenSparse at 300 dense coordinates


@dataclass(frozen=True, kw_only=True)
class RunSpec:
    """Settings of one implicit (generalized-alpha) run.

    end_time: simulated duration [s]. step: nominal (maximum) step [s].
    min_step: smallest step the retry logic may reach before failing [s].
    spectral_radius: rho_inf of Eq. (alpha_parameters), in [0, 1].
    newton_mode: "full" (Jacobian every iteration, default for contact),
    "per_step" (one Jacobian per step) or "modified" (Exudyn's modified Newton).
    max_newton_iterations: iterations per attempt.
    abs_tol [N], rel_tol [-]: Newton convergence, Eq. (acceptance) with W = I
    on Exudyn's residual norm.
    strict_abs_tol [N]: optional strict acceptance ||W r||_2 <= strict_abs_tol at
    the converged state, with W scaling rotational rows by 1/reference_length.
    reference_length [m]: the rotational residual scaling of Eq. (acceptance)
    (None: unscaled).
    adaptive: reject-and-retry with smaller steps on failure (else fail at once).
    linear_solver: "dense", "sparse" (Exudyn's EXUdense / EigenSparse) or
    "auto" (dense up to DENSE_MAX_COORDINATES coordinates, where dense LU is faster).
    backend ("warp" | "numpy"), precision ("float64" | "float32"), device
    ("cpu" | "cuda:N"): contact evaluation options.
    """
    end_time: float
    step: float
    min_step: float | None = None
    spectral_radius: float = 0.8
    newton_mode: str = "full"
    max_newton_iterations: int = 12
    abs_tol: float = 1e-8
    rel_tol: float = 1e-9
    strict_abs_tol: float | None = None
    reference_length: float | None = None
    adaptive: bool = True
    linear_solver: str = "auto"
    backend: str = "warp"
    precision: str = "float64"
    device: str = "cpu"

    def __post_init__(self):
        check_positive("end_time", self.end_time)
        check_range("step", self.step, 0.0, self.end_time, low_open=True)
        if self.min_step is not None:
            check_range("min_step", self.min_step, 0.0, self.step, low_open=True)
        check_range("spectral_radius", self.spectral_radius, 0.0, 1.0)
        check_choice("newton_mode", self.newton_mode, NEWTON_MODES)
        if not isinstance(self.max_newton_iterations, int) or self.max_newton_iterations < 1:
            raise RvtoolInputError(f"max_newton_iterations = {self.max_newton_iterations!r} is outside the valid range [1, inf)")
        check_positive("abs_tol", self.abs_tol)
        check_range("rel_tol", self.rel_tol, 0.0, 1.0, low_open=True)
        if self.strict_abs_tol is not None:
            check_positive("strict_abs_tol", self.strict_abs_tol)
        if self.reference_length is not None:
            check_positive("reference_length", self.reference_length)
        check_choice("backend", self.backend, ("warp", "numpy"))
        check_choice("linear_solver", self.linear_solver, ("auto", "dense", "sparse"))
        check_choice("precision", self.precision, ("float64", "float32"))
        if self.precision == "float32" and self.rel_tol < FLOAT32_REL_TOL_FLOOR:
            # float32 contact forces carry ~1e-7 relative round-off; a tighter Newton
            # tolerance can never be met and would only end in step rejections
            raise RvtoolInputError(f"rel_tol = {self.rel_tol} is below the float32 round-off floor; valid range "
                                   f"[{FLOAT32_REL_TOL_FLOOR}, 1] for precision 'float32'")

    @property
    def minimum_step(self):
        return self.min_step if self.min_step is not None else self.step * 1e-4

    def to_dict(self):
        d = asdict(self)
        d["integrator"] = "Exudyn generalized-alpha (Arnold-Bruls form, MainSolverImplicitSecondOrder)"
        return d
