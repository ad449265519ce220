"""Sphinx configuration of satfmu's documentation site: the README's walkthrough, docs/*.md and an
API reference generated from the docstrings (numpydoc). Built by ``make docs`` into
``build/docs`` (open ``build/docs/index.html``, offline), nitpicky: a cross-reference that
resolves to nothing is an error."""
from __future__ import annotations

import types
from pathlib import Path
from typing import Any, Generic

from satfmu import __version__

project = "satfmu"
author = "the satfmu developers"
copyright = "2026, the satfmu developers"  # noqa: A001 (Sphinx's name)
release = version = __version__

extensions = ["myst_parser", "sphinx.ext.autodoc", "sphinx.ext.autosummary", "numpydoc"]
source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
root_doc = "index"
exclude_patterns = ["_build", "_api/.*", "**/README.md"]
templates_path = ["_templates"]

# every public module of the facade and the four layers, one page each (docs/api.rst)
autosummary_generate = True
autosummary_ignore_module_all = True  # members defined in each module, submodules too
autodoc_default_options = {"members": True, "show-inheritance": True}
autodoc_typehints = "none"  # numpydoc's Parameters sections carry the types
autodoc_preserve_defaults = True  # a default shows as written in the source (a Model's repr does not parse)
numpydoc_show_class_members = False
numpydoc_xref_param_type = False

myst_heading_anchors = 3
myst_enable_extensions = ["colon_fence"]

nitpicky = True
# Sphinx cannot fetch other projects' inventories offline: names of the standard library and of
# the libraries satfmu builds on are left unlinked (and not reported); satfmu's own must resolve.
EXTERNAL = r"(numpy|np|scipy|sp|sympy|pandas|pd|pathlib|os|typing|collections|dataclasses|enum|fmpy|cvxpy|cp" \
           r"|clarabel|distributed|dask|matplotlib|lxml|xml|pythonfmu|zipfile|subprocess|io|types|abc|datetime" \
           r"|pytest|_pytest|concurrent|threading|ctypes|argparse|libcosimpy|pyarrow|jinja2|numbers|builtins)"
nitpick_ignore_regex = [
    (r"py:.*", EXTERNAL + r"\..*"),
    (r"py:class", r".* \| .*"),  # a union in a type alias's value ("alias of Callable[..., float | None]")
    (r"py:.*", r"(Path|Any|Callable|Sequence|Mapping|Iterable|Iterator|Literal|Optional|NDArray|ArrayLike"
               r"|ModuleType|PathLike|Element|Client|Future|DataFrame|Series|Figure|Axes)"),
]

html_theme = "alabaster"
html_title = f"satfmu {release}"
html_static_path: list[str] = []
html_show_sourcelink = False
# the generated result tables of docs/seed00*/ start with a caption, not a title (a hidden toctree)
suppress_warnings = ["toc.no_title"]



def _skip_type_aliases(app: object, what: str, name: str, obj: object, skip: bool, options: object) -> bool | None:
    """A type alias (``Bound = tuple[str, str, float, str]``) is not a class to document: skipped."""
    return True if isinstance(obj, types.GenericAlias) else None


def _write_facade_table(app: Any) -> None:
    """``_api/facade.rst``: the names the facade re-exports, each linking to the object where it is
    defined (documented there once, its references resolving in its own module)."""
    import satfmu

    names = sorted(satfmu._EXPORTS, key=str.lower)
    lines = [f"- ``satfmu.{n}``: :py:obj:`{satfmu._EXPORTS[n]}.{n}`" for n in names]
    out = Path(app.srcdir) / "_api" / "facade.rst"
    out.parent.mkdir(exist_ok=True)
    text = "\n".join(lines) + "\n"
    if not out.exists() or out.read_text() != text:
        out.write_text(text)


def _canonical(path: str) -> str | None:
    """The dotted name where the object ``path`` names is defined, when ``path`` reaches it
    through a re-export (``satfmu.Scenario``, ``satfmu.sims.campaign.engine.CampaignError``), else None."""
    import importlib

    parts = path.split(".")
    for split in range(len(parts) - 1, 0, -1):
        try:
            obj: Any = importlib.import_module(".".join(parts[:split]))
        except ImportError:
            continue
        try:
            for attr in parts[split:]:
                obj = getattr(obj, attr)
        except AttributeError:
            return None
        module, qualname = getattr(obj, "__module__", None), getattr(obj, "__qualname__", None)
        if isinstance(module, str) and isinstance(qualname, str) and f"{module}.{qualname}" != path:
            return f"{module}.{qualname}"
        return None
    return None


def _reexported_reference(app: Any, env: Any, node: Any, contnode: Any) -> Any:
    """A reference to an object through a name that re-exports it (the facade's ``satfmu.Scenario``,
    or ``Scenario`` in satfmu's own docstring; an error class through the module that raises it)
    resolves to the object where it is defined and documented. Anything else stays unresolved."""
    import satfmu

    if node.get("refdomain") != "py":
        return None
    target = node["reftarget"]
    candidates = [target] + ([f"{node['py:module']}.{target}"] if node.get("py:module") else [])
    for path in candidates:
        name = path.removeprefix("satfmu.")
        canonical = (f"{satfmu._EXPORTS[name]}.{name}" if name in satfmu._EXPORTS and "." not in name
                     and _canonical(path) is None else _canonical(path))  # data (SEED_000) has no __qualname__
        if canonical is not None:
            return env.get_domain("py").resolve_xref(env, node["refdoc"], app.builder, node["reftype"], canonical,
                                                     node, contnode)
    return None


def _plain_generic_bases(app: Any, name: str, obj: object, options: object, bases: list) -> None:
    """``class Campaign(Generic[_T])`` shows its base as ``Generic`` (its type variable is private)."""
    for i, base in enumerate(bases):
        if getattr(base, "__origin__", None) is Generic:
            bases[i] = Generic


def _drop_stale_pages(app: Any) -> None:
    """Remove the generated pages (``_api/satfmu.*.rst``) before autosummary writes today's: a page
    of a module that moved, or a package page listing a module that moved, would linger."""
    for page in (Path(app.srcdir) / "_api").glob("satfmu.*.rst"):
        page.unlink()


def _cache_numpydoc_template() -> None:
    """numpydoc (1.11) compiles its Jinja2 template anew for every docstring (a new environment per
    object): a fifth of the build. Its environment class is made to compile each template once."""
    import numpydoc.docscrape_sphinx as scrape

    base = scrape.SandboxedEnvironment
    if getattr(base, "compiled_once", False):
        return

    class CompiledOnce(base):  # type: ignore[misc, valid-type]
        compiled_once = True
        templates: dict[str, Any] = {}

        def get_template(self, name: Any, *args: Any, **kwargs: Any) -> Any:
            if not isinstance(name, str):
                return super().get_template(name, *args, **kwargs)
            if name not in self.templates:
                self.templates[name] = super().get_template(name, *args, **kwargs)
            return self.templates[name]

    scrape.SandboxedEnvironment = CompiledOnce


def setup(app: Any) -> None:
    _cache_numpydoc_template()
    app.connect("builder-inited", _drop_stale_pages, priority=100)  # before autosummary generates
    app.connect("autodoc-process-bases", _plain_generic_bases)
    app.connect("builder-inited", _write_facade_table)
    app.connect("autodoc-skip-member", _skip_type_aliases)
    app.connect("missing-reference", _reexported_reference)
