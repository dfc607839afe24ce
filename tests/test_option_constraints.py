"""Every option's forms are written once (its group's constraints table): a wrong value is refused for every option
of every group, from Python and from every command-line flag that sets one, and the defaults obey their tables."""

import dataclasses

import numpy as np
import pytest
from conftest import assert_usage_error, files, run

from manifill import GPOptions, Options, reconstruct_volume
from manifill.cli.main import build_parser
from manifill.cli.options import OPTION_FLAGS, choices_of, default_of, forms_of
from manifill.errors import OptionError
from manifill.io import write_mesh
from manifill.linalg.gp import as_gp_options
from manifill.mesh.shapes import icosphere
from manifill.solid.estimates import VOLUME_CONSTRAINTS
from manifill.surface.methods.registry import configure
from manifill.surface.options import CONSTRAINTS, GROUPS, OPTION_NAMES
from manifill.validate.constraints import Number, OneOf, check, invalid_value

GP_NAMES = [f.name for f in dataclasses.fields(GPOptions)]


def test_every_option_has_a_table_entry_and_its_default_obeys_it():
    assert sorted(CONSTRAINTS) == sorted(OPTION_NAMES)
    assert sorted(GPOptions.CONSTRAINTS) == sorted(GP_NAMES)
    for cls in GROUPS.values():
        assert sorted(cls.CONSTRAINTS) == sorted(f.name for f in dataclasses.fields(cls))
        for f in dataclasses.fields(cls):
            check(f.name, f.default, cls.CONSTRAINTS[f.name])
    for f in dataclasses.fields(GPOptions):
        check(f.name, f.default, GPOptions.CONSTRAINTS[f.name])


@pytest.mark.parametrize("name", OPTION_NAMES)
def test_a_wrong_value_of_every_option_is_refused_naming_it(name):
    bad = invalid_value(CONSTRAINTS[name])
    with pytest.raises(OptionError, match=rf"^{name}=") as e:
        Options.build(**{name: bad})
    assert "\n" not in str(e.value) and "pass one" in str(e.value)


@pytest.mark.parametrize("name", GP_NAMES)
def test_a_wrong_value_of_every_gp_option_is_refused_naming_it(name):
    bad = invalid_value(GPOptions.CONSTRAINTS[name])
    with pytest.raises(OptionError, match=rf"^gp {name}="):
        as_gp_options({name: bad})
    with pytest.raises(OptionError, match=rf"gp {name}="):  # as the entry points configure, before any work
        configure(Options.build(method="gp", gp={name: bad}))


@pytest.mark.parametrize("name", sorted(VOLUME_CONSTRAINTS))
def test_a_wrong_value_of_every_solid_option_is_refused_naming_it(name):
    V, F = icosphere(1)
    bad = invalid_value(VOLUME_CONSTRAINTS[name])
    with pytest.raises(OptionError, match=name):
        reconstruct_volume(V, F, np.arange(4), np.arange(4.0), **{name: bad})


def test_the_tables_say_what_the_old_checks_said():
    """A value each form takes passes; the closed sets are the modules' own tuples (one source)."""
    from manifill.linalg.backends import SOLVERS
    from manifill.surface.options import DUPLICATES

    assert choices_of("solver") == SOLVERS and choices_of("duplicates") == DUPLICATES
    assert default_of("solver") == "auto" and default_of("gp.variance") == "auto"
    o = Options.build(bounds=(0, None), smoothing="auto", tol=1e-9, maxiter=5, neighbours=8, levels=[0.0, 1.0],
                      trust=2.0, check=False, uncertainty=True, gp={"range": 0.3})
    assert o.fit.bounds == (0, None) and o.fill.neighbours == 8
    for bad in ({"neighbours": 5}, {"neighbours": 8.0}, {"tol": 0}, {"maxiter": 0}, {"bounds": (0, 1, 2)},
                {"trust": float("inf")}, {"check": 1}, {"seed": -1}):
        with pytest.raises(OptionError):
            Options.build(**bad)


@pytest.fixture(scope="module")
def case(tmp_path_factory):
    d = tmp_path_factory.mktemp("flags")
    V, F = icosphere(2)
    write_mesh(d / "m.ply", V, F)
    idx = np.arange(0, len(V), 11)
    (d / "s.csv").write_text("vertex,t\n" + "".join(f"{i},{float(V[i, 0])!r}\n" for i in idx))
    return d


def _cli_value(forms):
    """A wrong value on the command line for these forms."""
    if any(isinstance(f, OneOf) for f in forms):
        return "not-an-option"
    if any(isinstance(f, Number) for f in forms):
        return "-7"
    return "no-such-file.txt"


def test_every_flag_that_sets_an_option_exists():
    parser = build_parser()
    flags = {s for sub in parser._subparsers._group_actions[0].choices.values() for a in sub._actions
             for s in a.option_strings}
    assert set(OPTION_FLAGS) <= flags
    for name in OPTION_FLAGS.values():
        forms_of(name)  # every flag maps to an option with a table


@pytest.mark.parametrize("flag", sorted(OPTION_FLAGS))
def test_a_wrong_value_of_every_flag_is_one_line_and_exit_2(flag, case, capsys):
    name = OPTION_FLAGS[flag]
    value = _cli_value(forms_of(name))
    extra = ["--method", "gp"] if name.startswith("gp.") else []
    if flag == "--untrusted":
        extra = ["--trust", "2"]
    code, out, err = run(capsys, "reconstruct", case / "m.ply", case / "s.csv", "-o", case / "o.vtu", *extra,
                         f"{flag}={value}")
    line = assert_usage_error(code, out, err)
    short = name.split(".")[-1]
    assert flag in line or f"{short}=" in line or f"{short} " in line or value in line, line
    assert files(case) == ["m.ply", "s.csv"]
