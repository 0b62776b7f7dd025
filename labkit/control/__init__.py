"""Control: identify a joint from a recorded response, design its PID with python-control, and control
arms in simulation (computed torque vs PD on the dynamics) and on the arm (resolved-rate Cartesian
control by streaming joint set-points).
"""

from labkit.control import _experiment, _identify, _pid, _resolved_rate, _torque
from labkit.control._identify import StepFit, fit_step_response, model_response
from labkit.control._experiment import StepRecord, record_step, rate_limited_steps
from labkit.control._torque import computed_torque_controller, pd_controller, TrackingResult, simulate_tracking
from labkit.control._resolved_rate import resolved_rate_trajectory, PathTracking, track_on_arm
from labkit.control._pid import joint_plant, PIDDesign, design_pid

__all__ = [*_identify.__all__, *_experiment.__all__, *_torque.__all__, *_resolved_rate.__all__, *_pid.__all__]
