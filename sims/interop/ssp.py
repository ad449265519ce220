"""SSP 1.0 export of a scenario: its FMUs, connections and parameter values in one ``.ssp`` file.

An ``.ssp`` is a zip holding ``SystemStructure.ssd`` (the system: one ``ssd:Component`` per FMU
instance with the connectors it uses, the instance's parameter values inline as an
``ssv:ParameterSet``, one ``ssd:Connection`` per connected scalar pair, the default experiment)
and the FMUs under ``resources/``. Any SSP tool loads it; for libcosim (Open Simulation
Platform) the default experiment carries the fixed communication step as an
``com.opensimulationplatform`` annotation (``osp:FixedStepAlgorithm baseStepSize``, s), which
libcosim needs and other tools ignore; for OMSimulator the system carries it as an
``org.openmodelica`` annotation (``oms:SimulationInformation``, a fixed-step master ``oms-ma``:
OMSimulator 3 takes the kind of a system from it alone and refuses a file without one).

Everything is resolved as the master resolves it (:class:`satfmu.sims.cosim.master.CoSimulation`: base
names expanded index by index, causality and type checked, parameter values checked and
converted by :func:`satfmu.sims.cosim.master.start_value`), so an exported file is the scenario the master
runs. The file is validated against the SSP 1.0 schemas that fmpy ships
(``SystemStructureDescription.xsd``, and each parameter set against
``SystemStructureParameterValues.xsd``, which the SSD schema leaves unchecked) before it is
written.

Each disturbance profile becomes a signal-generator component (:mod:`satfmu.fmus.signals`, native)
named ``signal_<instance>_<variable>`` and connected to the input it drives, its output declaring
that input's unit (:func:`target_unit`, read from the target FMU: FMI 2.0 gives each variable one
fixed unit): the dimensionless generic ones (constant, step, sinusoid, cosine ramp) are taken
from the FMU folder, those of another unit (``signal_step__N_m``) and the sampled ones (table,
csv, random, igrf) are compiled into ``signal_tables`` there, with the profile's constants as
parameter values. The file is then the whole scenario: FMUs plus connections.
"""
from __future__ import annotations

import functools
import re
import zipfile
from pathlib import Path

from fmpy.ssp import ssd as fmpy_ssd
from lxml import etree

from satfmu.fmus import archive, build_record
from satfmu.fmus import export as fmu_export
from satfmu.fmus import signals
from satfmu.fmus.atomic import write_atomically
from satfmu.fmus.description import xml_value
from satfmu.sims.cosim.master import CoSimulation, start_value
from satfmu.controllers import catalog
from satfmu.sims.scenario.provisioning import fmu_paths
from satfmu.sims.scenario.run import check
from satfmu.sims.scenario.spec import Scenario, load
from satfmu.sims.scenario.wiring import grid, profiles
from satfmu.fmus.errors import SspError

NS = {"ssd": "http://ssp-standard.org/SSP1/SystemStructureDescription",
      "ssc": "http://ssp-standard.org/SSP1/SystemStructureCommon",
      "ssv": "http://ssp-standard.org/SSP1/SystemStructureParameterValues",
      "osp": "http://opensimulationplatform.com/SSP/OSPAnnotations",
      "oms": "https://raw.githubusercontent.com/OpenModelica/OMSimulator/master/schema/oms.xsd"}
"""Namespaces with the prefixes libcosim and OMSimulator require literally (they read the XML by
prefixed names)."""
OSP_ANNOTATION = "com.opensimulationplatform"
OMS_ANNOTATION = "org.openmodelica"
OMS_MASTER = "oms-ma"
"""OMSimulator's fixed-step co-simulation master (a weakly coupled system of co-simulation FMUs)."""
OMS_RELATIVE_TOLERANCE = 1e-4
"""The relative tolerance the OMSimulator annotation states (its default; a fixed-step master of
co-simulation FMUs does not use it)."""
SCHEMA_DIR = Path(fmpy_ssd.__file__).parent / "schema"
PARAMETER_SET = "scenario"
"""Name of every component's parameter set: ecos applies the sets of one name
(``--parameterSet scenario``); libcosim applies each component's inline set."""


def _q(name: str) -> str:
    prefix, local = name.split(":")
    return f"{{{NS[prefix]}}}{local}"


def _el(parent, tag: str, **attrib: str):
    return etree.SubElement(parent, _q(tag), attrib)


def target_unit(scenario: Scenario, fmu_dir: Path, target: str, backend: str = "native") -> str:
    """The declared unit of the input ``target`` (``instance.variable``) in its FMU's model
    description (``"1"`` when it declares none).

    Parameters
    ----------
    scenario : Scenario
        The scenario whose FMUs hold the input.
    fmu_dir : Path
        Folder of the FMUs named by ``model``.
    target : str
        The input, ``"instance.variable"`` (an indexed name such as ``"plant.T_d[1]"``).
    backend : {"native", "python"}, optional
        Default FMU backend of the scenario's instances. Default ``"native"``.

    Raises
    ------
    SspError
        If the instance or the variable does not exist.
    """
    inst, _, var = target.partition(".")
    path = fmu_paths(scenario, fmu_dir, backend).get(inst)
    if path is None:
        raise SspError(f"{scenario.name}: profile target {target!r}: no FMU instance {inst!r}")
    md = _model_description(str(path), path.stat().st_mtime_ns if path.is_file() else 0)
    for v in md.modelVariables:
        if v.name == var:
            unit = v.unit or (v.declaredType.unit if v.declaredType is not None else None)
            return unit or signals.DIMENSIONLESS
    raise SspError(f"{scenario.name}: profile target {target!r}: {path.name} has no variable {var!r}")


@functools.lru_cache(maxsize=32)
def _model_description(path: str, mtime_ns: int):
    """The model description of the FMU ``path`` (:func:`satfmu.fmus.archive.read_description`, read once
    per file version, ``mtime_ns``)."""
    return archive.read_description(path)


def signal_components(scenario: Scenario, fmu_dir: Path, table_dir: Path, backend: str = "native"
                      ) -> tuple[dict[str, Path], dict[str, dict], list[dict[str, str]]]:
    """The scenario's profiles as signal-generator instances: FMU paths, parameter values and
    connections (``from``/``to``), by instance name ``signal_<instance>_<variable>``.

    Each generator's output declares the unit of the input it drives (:func:`target_unit`, of
    the scenario's FMUs for ``backend``). The dimensionless generic generators come from
    ``fmu_dir`` (built there when missing); those of another unit and the table generators are
    compiled into ``table_dir`` (again when their build digest is not their model's).

    Parameters
    ----------
    scenario : Scenario
        The scenario whose profiles are turned into generators.
    fmu_dir : Path
        Folder of the scenario's FMUs and of the dimensionless generic generators.
    table_dir : Path
        Folder receiving the generators compiled for a unit or a table.
    backend : {"native", "python"}, optional
        Default FMU backend of the scenario's instances (the generators are native either way).
        Default ``"native"``.

    Returns
    -------
    paths : dict of str to Path
        Generator instance name -> FMU file.
    parameters : dict of str to dict
        Generator instance name -> {parameter name: value}: the profile's constants.
    connections : list of dict of str to str
        One ``{"from": "<generator>.<output>", "to": target}`` per profile.

    Raises
    ------
    satfmu.fmus.profiles.ProfileError
        An invalid profile.
    SspError
        A target that is not a variable of the scenario's FMUs.
    """
    paths: dict[str, Path] = {}
    params: dict[str, dict] = {}
    conns: list[dict[str, str]] = []
    times = grid(scenario)
    for target, prof in profiles(scenario):
        model, values = prof.generator(times, target_unit(scenario, fmu_dir, target, backend))
        inst = "signal_" + re.sub(r"[^A-Za-z0-9]+", "_", target).strip("_")
        if model.tables or model.name not in catalog.SIGNALS:
            path = fmu_export.fmu_path(model, table_dir, "native")
            if build_record.built_digest(path) != fmu_export.digest_of(model, "native"):
                path = fmu_export.build_native(model, table_dir)
        else:
            path = catalog.ensure(Path(fmu_dir), [model.name])[model.name]
        paths[inst], params[inst] = path, values
        conns.append({"from": f"{inst}.{signals.OUTPUT}", "to": target})
    return paths, params, conns


def system_structure(scenario: Scenario, fmu_dir: Path, backend: str = "native",
                     table_dir: Path | None = None) -> tuple[bytes, dict[str, Path]]:
    """``SystemStructure.ssd`` of ``scenario`` (validated) and the FMU files by resource path.

    Parameters
    ----------
    scenario : Scenario
        The scenario.
    fmu_dir : Path
        Folder of the FMUs.
    backend : {"native", "python"}, optional
        Default FMU backend of the scenario's instances. Default ``"native"``.
    table_dir : Path, optional
        Receives the compiled table generators of sampled profiles (default: a
        ``signal_tables`` folder in ``fmu_dir``).

    Returns
    -------
    ssd : bytes
        The XML document, UTF-8.
    resources : dict of str to Path
        FMU file by its path in the SSP file (``resources/<file name>``).

    Raises
    ------
    SspError
        Two different FMU files with one name, an instance name taken twice, an FMI 3.0 FMU, or a
        schema failure.
    FileNotFoundError, satfmu.sims.cosim.master.MasterError, satfmu.fmus.profiles.ProfileError
        A missing FMU, an unknown variable, a wrong connection, parameter or profile (as the master).
    """
    d = scenario.data
    paths = fmu_paths(scenario, fmu_dir, backend)
    fmi3 = sorted(inst for inst, path in paths.items() if archive.read_description(path).fmiVersion != "2.0")
    if fmi3:
        raise SspError(f"{scenario.name}: instance(s) {fmi3} are FMI 3.0 FMUs; an SSP 1.0 file connects FMI 2.0 "
                       "scalars (use the native or python backend)")
    table_dir = Path(table_dir) if table_dir is not None else Path(fmu_dir) / "signal_tables"
    table_dir.mkdir(parents=True, exist_ok=True)
    sig_paths, sig_params, sig_conns = signal_components(scenario, fmu_dir, table_dir, backend)
    taken = sorted(set(paths) & set(sig_paths))
    if taken:
        raise SspError(f"{scenario.name}: instance name(s) {taken} are taken by the scenario; the profiles' "
                       "signal generators need them")
    paths.update(sig_paths)
    instance_parameters = {inst: spec.get("parameters", {}) for inst, spec in d["fmus"].items()} | sig_params
    resources: dict[str, Path] = {}
    for inst, path in paths.items():
        key = f"resources/{path.name}"
        if resources.setdefault(key, path).resolve() != path.resolve():
            raise SspError(f"{scenario.name}: two different FMU files are named {path.name}")
    root = etree.Element(_q("ssd:SystemStructureDescription"), {"version": "1.0", "name": scenario.name},
                         nsmap=NS)
    system = _el(root, "ssd:System", name=scenario.name)
    if d.get("description"):
        system.set("description", d["description"])
    elements = _el(system, "ssd:Elements")
    with CoSimulation(paths) as sim:
        for c in list(d.get("connections", [])) + sig_conns:
            sim.connect(c["from"], c["to"])
        used: dict[str, list[str]] = {inst: [] for inst in paths}
        for src, dst in sim.connections:
            for q in (src, dst):
                inst, var = q.split(".", 1)
                if var not in used[inst]:
                    used[inst].append(var)
        for inst, path in paths.items():
            comp = sim.components[inst]
            el = _el(elements, "ssd:Component", name=inst, source=f"resources/{path.name}",
                     type="application/x-fmu-sharedlibrary")
            connectors = _el(el, "ssd:Connectors")
            for var in used[inst]:
                con = _el(connectors, "ssd:Connector", name=var, kind=comp.variable(var).causality)
                _el(con, "ssc:Real")
            values = instance_parameters[inst]
            if values:
                pset = _el(_el(_el(_el(el, "ssd:ParameterBindings"), "ssd:ParameterBinding"),
                               "ssd:ParameterValues"), "ssv:ParameterSet", version="1.0", name=PARAMETER_SET)
                params = _el(pset, "ssv:Parameters")
                for name, value in values.items():
                    var, value = start_value(comp, name, value)
                    _el(_el(params, "ssv:Parameter", name=name), f"ssv:{var.type}", value=xml_value(value, var.type))
        connections = _el(system, "ssd:Connections")
        for src, dst in sim.connections:
            (si, sv), (di, dv) = src.split(".", 1), dst.split(".", 1)
            _el(connections, "ssd:Connection", startElement=si, startConnector=sv, endElement=di, endConnector=dv)
    oms = _el(_el(system, "ssd:Annotations"), "ssc:Annotation", type=OMS_ANNOTATION)
    _el(_el(_el(oms, "oms:Annotations"), "oms:SimulationInformation"), "oms:FixedStepMaster", description=OMS_MASTER,
        stepSize=xml_value(d["step_size"], "Real"), relativeTolerance=xml_value(OMS_RELATIVE_TOLERANCE, "Real"))
    experiment = _el(root, "ssd:DefaultExperiment", startTime=xml_value(d.get("start_time", 0.0), "Real"),
                     stopTime=xml_value(d["stop_time"], "Real"))
    annotation = _el(_el(experiment, "ssd:Annotations"), "ssc:Annotation", type=OSP_ANNOTATION)
    _el(_el(annotation, "osp:Algorithm"), "osp:FixedStepAlgorithm", baseStepSize=xml_value(d["step_size"], "Real"))
    validate(root)
    return etree.tostring(root, xml_declaration=True, encoding="UTF-8", pretty_print=True), resources


def validate(root) -> None:
    """Check an SSD tree against the SSP 1.0 schemas (the description, and each inline parameter set).

    Parameters
    ----------
    root : lxml.etree.Element
        The ``ssd:SystemStructureDescription`` element.

    Raises
    ------
    SspError
        With every schema message.
    """
    checks = [("SystemStructureDescription.xsd", root)]
    checks += [("SystemStructureParameterValues.xsd", p) for p in root.iter(_q("ssv:ParameterSet"))]
    errors = []
    for xsd, el in checks:
        schema = etree.XMLSchema(file=str(SCHEMA_DIR / xsd))
        if not schema.validate(el):
            errors += [f"{xsd}: line {e.line}: {e.message}" for e in schema.error_log]
    if errors:
        raise SspError("the SSD fails the SSP 1.0 schema:\n" + "\n".join(errors))


def export(name_or_path: "str | Path | Scenario", fmu_dir: str | Path | None, out: Path, backend: str = "native",
           allow_stale: bool = False) -> Path:
    """Write the scenario as ``out`` (a ``.ssp`` file; a directory gets ``<scenario>.ssp``).

    The scenario is checked as a run checks it (:func:`satfmu.sims.scenario.run.check`: the FMU files,
    missing ones built, and the wiring) before anything is written, and an earlier file of
    that name is removed first: a refused or failed export leaves no file (:func:`write`).

    Parameters
    ----------
    name_or_path : str, Path or Scenario
        Shipped scenario name, TOML file, or the scenario itself.
    fmu_dir : str or Path, optional
        Folder of the FMUs; None: the FMU cache (:func:`satfmu.controllers.paths.fmu_cache`).
    out : Path
        The ``.ssp`` file, or a folder to receive ``<scenario>.ssp``.
    backend : {"native", "python"}, optional
        Default FMU backend of the scenario's instances. Default ``"native"``.
    allow_stale : bool, optional
        Use a stale controller FMU outside the FMU cache as it is (a warning), not an error.
        Default False.

    Returns
    -------
    Path
        The file written.

    Raises
    ------
    ScenarioError
        What a run refuses (the key path named), or an :class:`SspError`.
    """
    scenario = load(name_or_path)
    target(scenario, out).unlink(missing_ok=True)
    return write(scenario, check(scenario, fmu_dir, backend, allow_stale), out, backend)


def target(scenario: Scenario, out: Path) -> Path:
    """The file an export of ``scenario`` to ``out`` writes: ``out`` itself if it is a ``.ssp``
    path, else ``out/<scenario>.ssp``.

    Parameters
    ----------
    scenario : Scenario
        The scenario (its name).
    out : Path
        A ``.ssp`` file or a folder.
    """
    out = Path(out)
    return out if out.suffix == ".ssp" else out / f"{scenario.name}.ssp"


def write(scenario: Scenario, fmu_dir: Path, out: Path, backend: str = "native") -> Path:
    """Write a scenario :func:`satfmu.sims.scenario.run.check` accepted as an SSP file (:func:`target`),
    whole or not at all (:func:`satfmu.fmus.atomic.write_atomically`).

    Parameters
    ----------
    scenario : Scenario
        The scenario, already checked.
    fmu_dir : Path
        Folder of its FMUs (the one :func:`satfmu.sims.scenario.run.check` returned).
    out : Path
        The ``.ssp`` file, or a folder to receive ``<scenario>.ssp``.
    backend : {"native", "python"}, optional
        Default FMU backend of the scenario's instances. Default ``"native"``.

    Returns
    -------
    Path
        The file written.

    Raises
    ------
    SspError
    """
    ssd, resources = system_structure(scenario, Path(fmu_dir), backend)

    def zip_ssp(tmp: Path) -> None:
        with zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED) as zf:
            zf.writestr("SystemStructure.ssd", ssd)
            for arcname, path in resources.items():
                zf.write(path, arcname)

    return write_atomically(target(scenario, out), zip_ssp)
