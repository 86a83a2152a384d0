# SPDX-License-Identifier: BSD-3-Clause
# Type stub of the Python module `ehpt` (python/ehpt_module.cpp), installed next to it. Every
# public name and signature here is the module's: tests/python/test_stub.py compares them (names,
# parameters, defaults, annotations, the message classes' fields and defaults). Guide: docs/python.md.

import os
from typing import Any, Sequence

import numpy
import pandas
from numpy.typing import ArrayLike

__version__: str

class Problem:
    text: str
    where: str | None
    file: str | None
    line: int | None
    key: str | None
    column: str | None
    value: str | None
    message: str | None
    def __init__(self, text: str, where: str | None = None, file: str | None = None, line: int | None = None,
                 key: str | None = None, column: str | None = None, value: str | None = None,
                 message: str | None = None) -> None: ...

class Error(ValueError):
    problems: list[Problem]
    text: str
    where: str | None
    file: str | None
    line: int | None
    key: str | None
    column: str | None
    value: str | None
    message: str | None
    def __init__(self, text: str, problems: Sequence[Problem] = ()) -> None: ...

class Stamp:
    time_s: float
    step: int
    sequence: int
    def __init__(self, *, time_s: float = 0.0, step: int = 0, sequence: int = 0) -> None: ...

class PsdSensors:
    stamp: Stamp
    driverRequest: float
    speed_m_s: float
    iceW_rad_s: float
    icePowDel_W: float
    genW_rad_s: float
    genPowDel_W: float
    genTauLim_Nm: float
    motW_rad_s: float
    motPowDelA_W: float
    motPowDelB_W: float
    motPowDelAB_W: float
    motTauLim_Nm: float
    batSOC: float
    batPowDel_W: float
    battery_voltage_V: float
    battery_current_A: float
    fault: int
    locked: bool
    def __init__(self, *, stamp: Stamp = Stamp(), driverRequest: float = 0.0, speed_m_s: float = 0.0,
                 iceW_rad_s: float = 0.0, icePowDel_W: float = 0.0, genW_rad_s: float = 0.0,
                 genPowDel_W: float = 0.0, genTauLim_Nm: float = 0.0, motW_rad_s: float = 0.0,
                 motPowDelA_W: float = 0.0, motPowDelB_W: float = 0.0, motPowDelAB_W: float = 0.0,
                 motTauLim_Nm: float = 0.0, batSOC: float = 0.0, batPowDel_W: float = 0.0,
                 battery_voltage_V: float = 0.0, battery_current_A: float = 0.0, fault: int = 0,
                 locked: bool = False) -> None: ...

class PsdCommand:
    stamp: Stamp
    icePowRef_W: float
    iceTauRef_Nm: float
    genTauRef_Nm: float
    motTauRef_Nm: float
    iceON: bool
    def __init__(self, *, stamp: Stamp = Stamp(), icePowRef_W: float = 0.0, iceTauRef_Nm: float = 0.0,
                 genTauRef_Nm: float = 0.0, motTauRef_Nm: float = 0.0, iceON: bool = False) -> None: ...

class EvSensors:
    stamp: Stamp
    driverRequest_Nm: float
    speed_m_s: float
    driveW_rad_s: float
    driveTauLim_Nm: float
    drivePowDel_W: float
    batSOC: float
    batPowDel_W: float
    battery_voltage_V: float
    battery_current_A: float
    fault: int
    locked: bool
    def __init__(self, *, stamp: Stamp = Stamp(), driverRequest_Nm: float = 0.0, speed_m_s: float = 0.0,
                 driveW_rad_s: float = 0.0, driveTauLim_Nm: float = 0.0, drivePowDel_W: float = 0.0,
                 batSOC: float = 0.0, batPowDel_W: float = 0.0, battery_voltage_V: float = 0.0,
                 battery_current_A: float = 0.0, fault: int = 0, locked: bool = False) -> None: ...

class EvCommand:
    stamp: Stamp
    driveTauRef_Nm: float
    def __init__(self, *, stamp: Stamp = Stamp(), driveTauRef_Nm: float = 0.0) -> None: ...

class ShevSensors:
    stamp: Stamp
    driverRequest_Nm: float
    speed_m_s: float
    driveW_rad_s: float
    driveTauLim_Nm: float
    drivePowDc_W: float
    gensetW_rad_s: float
    gensetPowDc_W: float
    batSOC: float
    batPowDel_W: float
    battery_voltage_V: float
    battery_current_A: float
    fault: int
    locked: bool
    def __init__(self, *, stamp: Stamp = Stamp(), driverRequest_Nm: float = 0.0, speed_m_s: float = 0.0,
                 driveW_rad_s: float = 0.0, driveTauLim_Nm: float = 0.0, drivePowDc_W: float = 0.0,
                 gensetW_rad_s: float = 0.0, gensetPowDc_W: float = 0.0, batSOC: float = 0.0,
                 batPowDel_W: float = 0.0, battery_voltage_V: float = 0.0, battery_current_A: float = 0.0,
                 fault: int = 0, locked: bool = False) -> None: ...

class ShevCommand:
    stamp: Stamp
    driveTauRef_Nm: float
    gensetPowRef_W: float
    gensetON: bool
    def __init__(self, *, stamp: Stamp = Stamp(), driveTauRef_Nm: float = 0.0, gensetPowRef_W: float = 0.0,
                 gensetON: bool = False) -> None: ...

class RunResult:
    @property
    def summary(self) -> dict[str, Any]: ...
    @property
    def columns(self) -> list[str]: ...
    @property
    def timeseries(self) -> dict[str, numpy.ndarray]: ...
    @property
    def exit_code(self) -> int: ...
    @property
    def warnings(self) -> list[str]: ...
    @property
    def text(self) -> str: ...
    def to_dataframe(self) -> pandas.DataFrame: ...

def run(scenario: str | os.PathLike[str], set: dict[str, object] | None = None,
        cycle: tuple[ArrayLike, ArrayLike] | None = None, faults: Sequence[str] | None = None) -> RunResult: ...

class Simulation:
    def __init__(self, scenario: str | os.PathLike[str], set: dict[str, object] | None = None,
                 external_ecu: bool = False, chunk_steps: int = 50000,
                 cycle: tuple[ArrayLike, ArrayLike] | None = None, faults: Sequence[str] | None = None) -> None: ...
    def step(self, n: int) -> int: ...
    def run(self) -> int: ...
    def read_sensors(self) -> PsdSensors | EvSensors | ShevSensors: ...
    def write_command(self, command: PsdCommand | EvCommand | ShevCommand) -> None: ...
    def outputs(self) -> dict[str, float]: ...
    def timeseries(self) -> dict[str, numpy.ndarray]: ...
    def to_dataframe(self) -> pandas.DataFrame: ...
    def stats(self) -> dict[str, int | float | None]: ...
    def verdict(self) -> dict[str, Any] | None: ...
    @property
    def finished(self) -> bool: ...
    @property
    def time_s(self) -> float: ...
    @property
    def step_index(self) -> int: ...
    @property
    def total_steps(self) -> int: ...
    @property
    def chunk_steps(self) -> int: ...
    @property
    def external_ecu(self) -> bool: ...
    @property
    def step_s(self) -> float: ...
    @property
    def name(self) -> str: ...
    @property
    def ecu_period_steps(self) -> int | None: ...
    @property
    def ecu_parameters(self) -> dict[str, Any] | None: ...
    @property
    def signals(self) -> list[str]: ...
    @property
    def columns(self) -> list[str]: ...
