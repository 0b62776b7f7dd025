"""Measurements: the log schema, the crash-safe log, CSV loading, measurement
sessions, calculated values, error tables, the published-table audit and
calibration.
"""

from labkit.measure._schema import (
    COLUMNS,
    REQUIRED_COLUMNS,
    UNITS,
    MeasurementRecord,
    MeasurementWarning,
    quantity_dimension,
    to_si,
    parse_numbers,
)
from labkit.measure._log import MeasurementLog
from labkit.measure._csv import load_measurements
from labkit.measure._session import (
    Source,
    PlannedPose,
    MeasurementSession,
    joint_sweep_plan,
    SEED000_SWEEPS,
    prompt_reading,
    manual_form,
)
from labkit.measure._calculated import COMBINE_RULES, decimals_for_resolution
from labkit.measure._errortables import ErrorTable, error_table, fk_error_table, ik_error_table
from labkit.measure._audit import AuditResult, audit_published, load_published
from labkit.measure._errormodels import ERROR_MODELS
from labkit.measure._calibration import (
    GROUPS,
    CalibrationResult,
    calibrate,
    parameter_names,
    apply_parameters,
    predict_positions,
)

__all__ = [
    "COLUMNS",
    "REQUIRED_COLUMNS",
    "UNITS",
    "MeasurementRecord",
    "MeasurementWarning",
    "quantity_dimension",
    "to_si",
    "parse_numbers",
    "MeasurementLog",
    "load_measurements",
    "Source",
    "PlannedPose",
    "MeasurementSession",
    "joint_sweep_plan",
    "SEED000_SWEEPS",
    "prompt_reading",
    "manual_form",
    "COMBINE_RULES",
    "decimals_for_resolution",
    "ErrorTable",
    "error_table",
    "fk_error_table",
    "ik_error_table",
    "AuditResult",
    "audit_published",
    "load_published",
    "GROUPS",
    "ERROR_MODELS",
    "CalibrationResult",
    "calibrate",
    "parameter_names",
    "apply_parameters",
    "predict_positions",
]
