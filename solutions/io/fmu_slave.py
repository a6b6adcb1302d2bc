"""The slave of an mbd-course FMU (``fmu.py`` builds it): FMI 3.0 co-simulation of a model's forward dynamics.

pythonfmu3's loader imports this module from the FMU's resources (as ``fmu_slave``, the resources folder first on
``sys.path``, so that the ``solutions`` package the FMU carries is the one imported where none was before) and
instantiates the class below; its methods are FMI's: initialization, doStep, get and set of variables. The model
file is the FMU's ``resources/model.yaml``; the names of the variables are ``fmu.py``'s (its docstring).
"""

from __future__ import annotations

import re
from pathlib import Path

from pythonfmu3 import (
    DefaultExperiment,
    Float64,
    Fmi3Causality,
    Fmi3Slave,
    Fmi3Status,
    Fmi3StepResult,
    Fmi3Variability,
)

from solutions.diagnostics import AnalysisError
from solutions.io.fmu import MODEL_FILE, fmi_name, model_parameters, start_stepper, with_parameters
from solutions.io.model import ModelError, read_text

TOLERANCES = {
    "rtol": "relative tolerance of the integrator (the model file's simulation.rtol, or mbd run's rule for it)",
    "atol": "absolute tolerance of the integrator",
}


class MbdModel(Fmi3Slave):
    """A model of ``resources/model.yaml``: parameters from its numbers, outputs the columns of ``mbd run``."""

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.data = read_text(Path(self.resources) / MODEL_FILE)
        self.in_file = {name: value for name, (_, value) in model_parameters(self.data).items()}
        self.stepper = start_stepper(self.data)
        model, settings, tolerances = self.stepper.model, self.stepper.settings, self.stepper.tolerances
        self.values = {**self.in_file, **dict(zip(TOLERANCES, tolerances or (), strict=False))}
        self.modelName = re.sub(r"\W|^(?=\d)", "_", model.name)
        self.description = (
            f"{model.name}: {self.stepper.method}, by mbd-course in co-simulation; outputs are the columns of mbd "
            "run --out FILE.csv"
        )
        rtol = tolerances[0] if tolerances else None
        self.default_experiment = DefaultExperiment(0.0, settings.t_end, settings.t_end / settings.steps, rtol)
        time = Float64("time", causality=Fmi3Causality.independent, variability=Fmi3Variability.continuous)
        time.getter = lambda: self.stepper.t
        self.register_variable(time, nested=False)
        for name in self.values:
            self.register_variable(self._parameter(name), nested=False)
        for column in self.stepper.columns:
            self.register_variable(self._output(column), nested=False)

    def _parameter(self, name: str) -> Float64:
        """A parameter: a number of the model file (``fmu.model_parameters``), or a tolerance."""
        where = TOLERANCES.get(name, "a number of the model file, set before initialization")
        return Float64(
            name, causality=Fmi3Causality.parameter, variability=Fmi3Variability.fixed, start=self.values[name],
            description=where, getter=lambda: self.values[name], setter=lambda value: self.values.update({name: value}),
        )  # fmt: skip

    def _output(self, column: str) -> Float64:
        """An output: the result column ``column`` at the communication point reached."""
        return Float64(
            fmi_name(column), causality=Fmi3Causality.output, variability=Fmi3Variability.continuous,
            description=f"column {column} of mbd run --out FILE.csv", getter=lambda: self.stepper.columns[column],
        )  # fmt: skip

    def exit_initialization_mode(self):
        """Start the run again from the edited model when a parameter was set to another value than the file's."""
        edited = {name: value for name, value in self.values.items() if self.in_file.get(name, value) != value}
        tolerances = tuple(self.values[name] for name in TOLERANCES if name in self.values) or None
        if edited or tolerances != self.stepper.tolerances:
            try:
                self.stepper = start_stepper(with_parameters(self.data, edited), *(tolerances or ()))
            except (ModelError, AnalysisError) as err:
                self.log(f"parameters {', '.join(edited)}: {err}", Fmi3Status.error)
                raise

    def do_step(self, current_time: float, step_size: float):
        """Advance the motion from ``current_time`` (the time reached) to ``current_time + step_size``."""
        try:
            self.stepper.advance(current_time + step_size, current_time)
        except AnalysisError as err:
            self.log(str(err), Fmi3Status.error)
            return Fmi3StepResult(status=Fmi3Status.error, terminateSimulation=True)
        return True
