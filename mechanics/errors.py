"""The exception raised when the time loop cannot go on (docs/model.md §8.2: step below h_min, non-finite state, ...),
and the warning of a contact law used beyond its validity (docs/model.md §5.2)."""
import numpy as np


class IntegrationError(RuntimeError):
    """The integrator stopped: `time` is where, `state` the last accepted state, `reason` why."""

    def __init__(self, reason: str, time: float, state: np.ndarray):
        self.reason = reason
        self.time = float(time)
        self.state = np.array(state, copy=True)
        super().__init__(f"integration stopped at t = {self.time:.9g} s: {reason}; "
                         f"state = {np.array2string(self.state, precision=6)}")

    def __reduce__(self):
        """Rebuild from (reason, time, state), so the error crosses process pools (pickling)."""
        return type(self), (self.reason, self.time, self.state)


class ContactLawWarning(UserWarning):
    """A contact penetrated beyond its force law's validity limit; the law continued along its tangent
    (docs/model.md §5.2). Issued once per run; `Simulation.contact_law_excess` holds the largest excess."""
