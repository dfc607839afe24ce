"""Sphinx configuration of manifill's documentation.

Build (offline: nothing is fetched at build time), from the repository's root::

    pip install -e ".[docs]"
    python -m sphinx -W --keep-going -b html docs docs/_build/html

``MANIFILL_DOCS_GALLERY`` chooses which gallery scripts run: unset or ``1`` runs every
``examples/plot_*.py`` (the default); ``0`` runs none (pages with code, no pictures);
anything else is a regular expression matched against the scripts' paths
(``MANIFILL_DOCS_GALLERY=plot_barriers`` runs that one). ``-D plot_gallery=0`` works too.
"""

import os
import re
import sys
from pathlib import Path

import pyvista
from docutils.parsers.rst import Directive, directives

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
# a fresh clone without `pip install -e .` still finds the package
if str(ROOT / "src") not in sys.path:
    sys.path.insert(0, str(ROOT / "src"))

import manifill  # noqa: E402

# -- pyvista in the gallery: off screen, its plotters captured by the scraper ---------------------------------------
pyvista.OFF_SCREEN = True
pyvista.BUILDING_GALLERY = True
pyvista.set_plot_theme("document")
os.environ.setdefault("PYVISTA_OFF_SCREEN", "true")
os.environ.setdefault("MPLBACKEND", "Agg")

# -- project -------------------------------------------------------------------------------------------------------
project = "manifill"
author = "the manifill developers"
copyright = "the manifill developers (MIT License)"
version = release = manifill.__version__

# -- general -------------------------------------------------------------------------------------------------------
extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "numpydoc",
    "sphinx_gallery.gen_gallery",
    "myst_parser",
]
templates_path = ["_templates"]
source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
root_doc = "index"
# The Markdown pages of docs/ are included into .rst pages (benchmarks.rst, architecture.rst, notes.rst), and
# CHANGELOG.md into whats_new.rst: they are not documents of their own. The gallery's own sources are examples/.
exclude_patterns = [
    "_build",
    "benchmarks.md",
    "ARCHITECTURE.md",
    "NOTES.md",
    "auto_examples/*.ipynb",
    "auto_examples/*.py",
    "auto_examples/*.zip",
    "auto_examples/*.md5",
    "auto_examples/*.json",
]
default_role = "py:obj"  # `name` links to the API like :py:obj:`name`
nitpicky = False  # docstrings name private modules (manifill.results.Result, ...) that are not documented pages
pygments_style = "sphinx"
language = "en"

# -- autodoc / autosummary -----------------------------------------------------------------------------------------
autosummary_generate = True
autosummary_imported_members = True
autodoc_default_options = {"member-order": "bysource"}
autodoc_typehints = "none"  # the numpydoc sections say the types
autoclass_content = "class"

# -- numpydoc ------------------------------------------------------------------------------------------------------
numpydoc_show_class_members = False  # the class template lists the members (autodoc), not numpydoc
numpydoc_show_inherited_class_members = False
numpydoc_class_members_toctree = False
numpydoc_attributes_as_param_list = True
numpydoc_xref_param_type = False  # types are plain text: "(n, 3) array" is not a name to link
numpydoc_validation_checks = set()  # `python docs/numpydoc_report.py` runs numpydoc's validation apart

# -- myst (the Markdown pages included: benchmarks.md, ARCHITECTURE.md, NOTES.md, CHANGELOG.md) --------------------
myst_enable_extensions = ["colon_fence"]
myst_heading_anchors = 3  # "#uncertainty"-style links inside a page resolve to its headings

# -- sphinx-gallery ------------------------------------------------------------------------------------------------
_gallery = os.environ.get("MANIFILL_DOCS_GALLERY", "1").strip()
_examples = ROOT / "examples"
sphinx_gallery_conf = {
    "examples_dirs": "../examples",
    "gallery_dirs": "auto_examples",
    "filename_pattern": r"/plot_" if _gallery in ("", "1") else (r"(?!)" if _gallery == "0" else _gallery),
    "plot_gallery": "True",
    "image_scrapers": ("matplotlib", "pyvista"),
    "download_all_examples": False,
    "remove_config_comments": True,
    "within_subsection_order": "FileNameSortKey",
    "doc_module": ("manifill",),
    "backreferences_dir": "generated/backreferences",
    "reference_url": {"manifill": None},  # links from the examples' code into this API, nothing remote
    "show_memory": False,
    # its timing page loads jQuery, Bootstrap and DataTables from CDNs: not written
    "write_computation_times": False,
    "min_reported_time": 1,
    "abort_on_example_error": False,
    "only_warn_on_example_error": False,
}
if not (_examples / "README.rst").exists() and not (_examples / "README.txt").exists():
    # examples/ not written yet: no gallery, and a page that says so (so the toctree entry still resolves)
    extensions.remove("sphinx_gallery.gen_gallery")
    (HERE / "auto_examples").mkdir(exist_ok=True)
    (HERE / "auto_examples" / "index.rst").write_text(
        "Gallery\n=======\n\nThe gallery is built from ``examples/plot_*.py``; this checkout has none yet.\n")

# -- HTML: pydata-sphinx-theme, with nothing loaded from the network ------------------------------------------------
html_theme = "pydata_sphinx_theme"
html_title = f"manifill {version}"
html_static_path = ["_static"]
html_css_files = ["manifill.css"]
html_show_sourcelink = False
html_copy_source = False
html_theme_options = {
    # every asset (Bootstrap, FontAwesome, the theme's CSS and JS) ships inside the theme's package; these keep it so:
    "analytics": {},  # no analytics script
    "switcher": None,  # no version switcher (it would fetch a JSON file)
    "check_switcher": False,
    "announcement": "",  # an announcement given as a URL is fetched by the browser
    "icon_links": [],  # no icons fetched from anywhere
    "show_version_warning_banner": False,
    "navbar_end": ["theme-switcher"],
    "footer_start": ["copyright"],
    "footer_end": [],
    "secondary_sidebar_items": ["page-toc"],
    "show_toc_level": 2,
    "navigation_with_keys": False,
    "header_links_before_dropdown": 6,
    "primary_sidebar_end": [],  # not the theme's default "sidebar-ethical-ads"
}
html_sidebars = {"index": [], "getting_started": [], "whats_new": []}
html_context = {"default_mode": "light"}

# -- checks --------------------------------------------------------------------------------------------------------
_REMOTE = re.compile(r"""<(?:script|link|img)\b[^>]*\b(?:src|href)=["'](?:https?:)?//""", re.I)


def _no_remote_assets(app, exception):
    """Warn (an error under -W) when a page would load a script, stylesheet or image from the network.

    MathJax, for one, comes from a CDN on any page with math: the docs have none.
    """
    if exception is not None or app.builder.format != "html":
        return
    bad = []
    pages = [Path(app.builder.get_outfilename(doc)) for doc in sorted(app.env.found_docs) + ["genindex", "search"]]
    for page in (p for p in pages if p.exists()):
        for m in _REMOTE.finditer(page.read_text(encoding="utf-8", errors="replace")):
            bad.append(f"{page.relative_to(app.outdir)}: {m.group(0)[:120]}")
    if bad:
        from sphinx.util import logging

        logging.getLogger(__name__).warning("pages load assets from the network:\n  " + "\n  ".join(bad[:20]))


#: the modules whose ``__all__`` api.rst must list in full
API_MODULES = ("manifill", "manifill.adapters.mne", "manifill.adapters.sklearn", "manifill.adapters.globe")


def _api_complete(app):
    """Warn about a public name (an ``__all__`` entry) that api.rst does not list, or one it lists twice."""
    import importlib

    from sphinx.util import logging

    listed, module = {}, None
    for line in (HERE / "api.rst").read_text(encoding="utf-8").splitlines():
        m = re.match(r"\.\. currentmodule:: (\S+)", line)
        if m:
            module = m.group(1)
        elif re.fullmatch(r"   [A-Za-z_][A-Za-z0-9_]*", line) and module:
            key = f"{module}.{line.strip()}"
            listed[key] = listed.get(key, 0) + 1
    for name in API_MODULES:
        for public in importlib.import_module(name).__all__:
            count = listed.get(f"{name}.{public}", 0)
            if count != 1:
                logging.getLogger(__name__).warning(
                    f"api.rst lists {name}.{public} {count} times (every public name once)")


class _NoMinigallery(Directive):
    """``minigallery`` when examples/ does not exist yet (the gallery's extension is off): nothing."""

    has_content = True
    optional_arguments = 1
    final_argument_whitespace = True
    option_spec = {"add-heading": directives.unchanged, "heading-level": directives.unchanged}

    def run(self):
        return []


def _skip_sklearn_routing(app, what, name, obj, skip, options):
    """Leave out scikit-learn's metadata-routing methods (``set_fit_request``, ``get_metadata_routing``, ...).

    scikit-learn adds them to every estimator; their docstrings point into scikit-learn's own glossary and user
    guide, which are not pages here. Nothing of manifill's own is skipped.
    """
    module = getattr(obj, "__module__", "") or ""
    if module.startswith("sklearn.utils._metadata_requests"):
        return True
    return None


def setup(app):
    app.connect("builder-inited", _api_complete)
    app.connect("autodoc-skip-member", _skip_sklearn_routing)
    app.connect("build-finished", _no_remote_assets)
    if "sphinx_gallery.gen_gallery" not in extensions:
        app.add_directive("minigallery", _NoMinigallery)
