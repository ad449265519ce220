"""An artifact's texts never become code: breakout strings in every text field that reaches a
generated source or the model description, through both backends.

Each string tries to end the literal or comment it lands in and run code that writes a
sentinel file. The FMU must build (its generated C and Python compile), carry the text back
unchanged in its modelDescription.xml, and load and run with the sentinel still absent.
"""
from __future__ import annotations

import copy
import json
import warnings
import zipfile
from pathlib import Path

import pytest

from satfmu.controllers import artifact
from satfmu.fmus import archive
from satfmu.controllers import catalog, paths

BASE = json.loads((paths.SHIPPED_ARTIFACTS / "mrp_hinf_published.json").read_text())

FIELDS = {
    "description": ("description",),
    "outputs[0].description": ("outputs", 0, "description"),
    "provenance.design_plant.model": ("provenance", "design_plant", "model"),
}
"""The artifact's text fields that reach the FMU: its description (with the design plant's name
appended) and the command's description."""


def breakouts(sentinel: Path) -> dict[str, str]:
    """Strings that end a Python or C literal or comment and then run code writing ``sentinel``."""
    code = f"__import__('pathlib').Path({str(sentinel)!r}).write_text('ran')"
    return {
        "triple quotes": f'x"""\n    {code}\n    """y',
        "single triple quotes": f"x'''\n{code}\n'''y",
        "backslashes": f'x\\"""; {code} #\\\\',
        "newlines": f"first line\n{code}\n# last line\r\n",
        "C comment end": f'*/ int satfmu_breakout = system("touch {sentinel}"); /* {code}',
        "format braces": "{cls} {generated} {description} %s %d",
    }


def _with(field: tuple, text: str) -> dict:
    data = copy.deepcopy(BASE)
    node = data
    for key in field[:-1]:
        node = node[key]
    node[field[-1]] = text
    return data


def _all_fields(text: str) -> dict:
    data = copy.deepcopy(BASE)
    for field in FIELDS.values():
        node = data
        for key in field[:-1]:
            node = node[key]
        node[field[-1]] = text
    return data


@pytest.mark.parametrize("backend", ["native", "python"])
@pytest.mark.parametrize("kind", list(breakouts(Path("/x"))))
def test_breakout_strings_stay_text(kind: str, backend: str, tmp_path: Path) -> None:
    sentinel = tmp_path / "sentinel"
    text = breakouts(sentinel)[kind]
    src = catalog.controller_source(artifact.parse(_all_fields(text)))
    fmu = catalog.builder(backend)(src.model, tmp_path / "fmus", src.resources)
    assert not sentinel.exists(), "building the FMU ran the artifact's text"
    md = archive.read_description(fmu)
    assert md.description.startswith(text + ". Designed for " + text + " (")
    assert {v.name: v.description for v in md.modelVariables}["u[1]"] == text
    with zipfile.ZipFile(fmu) as z:
        for name in z.namelist():
            if name.endswith(".py"):  # pythonfmu's slave script and satfmu's generated module
                compile(z.read(name), name, "exec")
    from fmpy import simulate_fmu

    res = simulate_fmu(str(fmu), stop_time=0.02, output_interval=0.01,
                       start_values={"omega[1]": 0.01})
    assert len(res) >= 2 and not sentinel.exists(), "loading or running the FMU ran the artifact's text"


@pytest.mark.parametrize("field", FIELDS)
@pytest.mark.parametrize("char", ["\x00", "\x1b", "\ufffe"])
def test_a_text_xml_cannot_carry_is_refused_with_its_key(field: str, char: str) -> None:
    with pytest.raises(artifact.ArtifactError, match=rf"artifact\.{'.*'.join(map(str, FIELDS[field]))}: holds "
                                              rf"U\+{ord(char):04X}"):
        artifact.parse(_with(FIELDS[field], f"text {char} more"))


def test_a_model_name_is_a_c_identifier() -> None:
    from satfmu.fmus.model import Model, ModelDefinitionError

    with pytest.raises(ModelDefinitionError, match=r"model name 'a\*/b' is not a C identifier"):
        Model(name="a*/b", description="", states=[], inputs=[], parameters=[], outputs=[])


def test_a_user_artifact_shadowing_a_shipped_one_is_reported(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv(paths.HOME_ENV, str(tmp_path))
    (tmp_path / "artifacts").mkdir()
    mine = tmp_path / "artifacts" / "mrp_hinf_published.json"
    shipped = paths.SHIPPED_ARTIFACTS / "mrp_hinf_published.json"
    mine.write_bytes(shipped.read_bytes())  # the same bytes: nothing to report
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert paths.find_artifact("mrp_hinf_published") == mine
    mine.write_text(json.dumps(_with(("description",), "my own"), indent=1))
    with pytest.warns(paths.ShadowedArtifactWarning, match=rf"{mine} shadows the shipped artifact {shipped}"):
        assert paths.find_artifact("mrp_hinf_published") == mine

