"""Labs: making a lab for any arm from the generic templates (:func:`new_lab`,
``labkit new``) and opening labs in JupyterLab (:func:`serve_lab`, ``labkit lab``).
"""

from labkit.labs._new import TEMPLATE_DIR, LabDefaults, NewLab, lab_defaults, new_lab, template_values, with_servos
from labkit.labs._serve import lab_command, live_figures, serve_lab

__all__ = [
    "TEMPLATE_DIR",
    "LabDefaults",
    "NewLab",
    "lab_defaults",
    "new_lab",
    "template_values",
    "with_servos",
    "lab_command",
    "live_figures",
    "serve_lab",
]
