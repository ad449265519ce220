"""Shared set-up of the pythonfmu 0.7.0 reproductions in this folder (fmpy and pythonfmu only).

Each script takes the path of a pythonfmu FMU (``build/fmus/*_py.fmu``, say); without one it
builds :func:`trivial_fmu`, a one-variable pythonfmu FMU of ten lines that uses nothing of
satfmu, so the defect is shown in pythonfmu itself. A script makes its call and prints one line
(what the call returned and logged); a crash ends the process with the signal instead. Run
each in a process of its own: ``python scripts/upstream/<name>.py [FMU]``; the extracted FMU
goes to a new folder in the temporary folder (``TMPDIR``), left there (a crash skips any
clean-up). ``python scripts/upstream/common.py FOLDER`` builds the trivial FMU in ``FOLDER``.
"""
from __future__ import annotations

import ctypes
import pathlib
import sys
import tempfile
from typing import Any

from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave, fmi2CallbackFunctions, fmi2CallbackLoggerTYPE

FMI2_MODEL_EXCHANGE, FMI2_CO_SIMULATION = 0, 1

TRIVIAL_SLAVE = '''
from pythonfmu import Fmi2Causality, Fmi2Slave, Real


class Trivial(Fmi2Slave):
    """y = the communication time at the end of the last step."""

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.y = 0.0
        self.register_variable(Real("y", causality=Fmi2Causality.output))

    def do_step(self, current_time, step_size):
        self.y = current_time + step_size
        return True
'''


def trivial_fmu(folder: pathlib.Path) -> pathlib.Path:
    """Build ``Trivial.fmu`` (pythonfmu's builder, FMU state enabled) in ``folder``."""
    from pythonfmu.builder import FmuBuilder

    script = folder / "Trivial.py"
    script.write_text(TRIVIAL_SLAVE)
    return FmuBuilder.build_FMU(script, dest=folder, canGetAndSetFMUstate=True, canSerializeFMUstate=True)


class Fmu:
    """An extracted FMU, its library loaded, and a logger that prints what the FMU logs.

    Parameters
    ----------
    argv : list of str
        The script's arguments: the FMU path, or none (then :func:`trivial_fmu` is built).
    """

    def __init__(self, argv: list[str]) -> None:
        self._tmp = tempfile.mkdtemp(prefix="pythonfmu_repro_")
        path = pathlib.Path(argv[0]) if argv else trivial_fmu(pathlib.Path(self._tmp))
        self.md = read_model_description(str(path))
        self.unzip = str(extract(str(path), unzipdir=str(pathlib.Path(self._tmp) / "unzipped")))
        self.slave = FMU2Slave(guid=self.md.guid, unzipDirectory=self.unzip,
                               modelIdentifier=self.md.coSimulation.modelIdentifier, instanceName="repro")
        self.resources = pathlib.Path(self.unzip, "resources").as_uri()
        self.messages: list[str] = []

        def logger(env: Any, name: bytes, status: int, category: bytes, message: bytes) -> None:
            self.messages.append(f"[{status}] {(message or b'').decode(errors='replace')}")

        self.callbacks = fmi2CallbackFunctions()
        self.callbacks.logger = fmi2CallbackLoggerTYPE(logger)

    def instantiate(self, name: bytes | None = b"repro", fmu_type: int = FMI2_CO_SIMULATION,
                    guid: bytes | None = None, resources: bytes | None = None) -> Any:
        """fmi2Instantiate with logging on; the arguments default to the right ones."""
        return self.slave.fmi2Instantiate(name, fmu_type, self.md.guid.encode() if guid is None else guid,
                                          self.resources.encode() if resources is None else resources,
                                          ctypes.byref(self.callbacks), 0, 1)

    def call(self, function: str, *args: Any) -> int:
        """The raw ``fmi2*`` function ``function`` (fmpy's argument types): its status, not raised."""
        return getattr(self.slave.dll, function)(*args)

    def ready(self) -> Any:
        """An instance after fmi2ExitInitializationMode (fmpy's calls raise if one fails)."""
        self.slave.component = self.instantiate()
        self.slave.setupExperiment(startTime=0.0)
        self.slave.enterInitializationMode()
        self.slave.exitInitializationMode()
        return self.slave.component


def report(line: str) -> None:
    """Print the result line (flushed: the process may crash right after)."""
    print(line, flush=True)
    sys.stdout.flush()


if __name__ == "__main__":  # python scripts/upstream/common.py FOLDER: build the trivial FMU there
    print(trivial_fmu(pathlib.Path(sys.argv[1])))
