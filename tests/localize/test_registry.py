"""The localizer registry: names, specs, plug-ins and scikit-learn style parameters."""

from __future__ import annotations

import math
import re
import textwrap
import uuid

import numpy as np
import pytest
from helpers import ideal_frame

import azgym
from azgym import InvalidInputError, Localizer, UnknownNameError
from azgym.localize import registry
from azgym.localize.loo import LeaveOneOut
from azgym.localize.lsq import LeastSquares
from azgym.localize.mex import Mex
from azgym.localize.ransac import Ransac
from azgym.localize.triplet import Triplet

BUILTINS = {"triplet": Triplet, "ransac": Ransac, "mex": Mex, "lsq": LeastSquares,
            "loo": LeaveOneOut}

PLUGIN_SOURCE = textwrap.dedent('''
    """A plug-in localizer: least squares with a counter, for the registry tests."""

    import azgym
    from azgym.localize.lsq import LeastSquares


    class Wrapped(azgym.Localizer):
        name = "wrapped"

        def __init__(self, *, max_iter=50, tag="plain"):
            self.max_iter = max_iter
            self.tag = tag
            self.calls = 0

        def _localize(self, problem):
            self.calls += 1
            return LeastSquares(max_iter=self.max_iter)._localize(problem)


    def not_a_localizer():
        return 42
''')


@pytest.fixture
def clean_registry(monkeypatch):
    """Registrations made by a test are forgotten afterwards."""
    monkeypatch.setattr(registry.LOCALIZERS, "_entries", dict(registry.LOCALIZERS._entries))


def test_builtins_are_listed():
    assert set(BUILTINS) <= set(azgym.list_localizers())
    assert azgym.list_localizers() == sorted(azgym.list_localizers())


@pytest.mark.parametrize(("name", "cls"), sorted(BUILTINS.items()))
def test_builtins_build_their_class(name, cls):
    localizer = azgym.make_localizer(name)
    assert type(localizer) is cls
    assert cls.name == name


def test_unknown_name_suggests_the_closest():
    with pytest.raises(UnknownNameError, match=re.escape("Did you mean 'ransac'?")) as info:
        azgym.make_localizer("ransak")
    assert "lsq" in str(info.value)  # the valid names are listed


def test_unknown_name_without_a_close_match():
    with pytest.raises(UnknownNameError, match=re.escape("unknown localizer 'qqqqqqqq'")) as info:
        azgym.make_localizer("qqqqqqqq")
    assert "Did you mean" not in str(info.value)


def test_name_must_be_a_string():
    with pytest.raises(InvalidInputError, match=re.escape("localizer name must be a string")):
        azgym.make_localizer(3)


def test_a_misspelt_hyperparameter_names_the_closest_and_the_valid_ones():
    with pytest.raises(InvalidInputError, match=re.escape(
            "localizer 'ransac': unknown hyperparameter 'wieghted'. Did you mean 'weighted'? "
            "Valid hyperparameters: coverage, degeneracy_tol,")) as info:
        azgym.make_localizer("ransac", wieghted=True)
    assert "random_state, weighted." in str(info.value)
    with pytest.raises(InvalidInputError, match=re.escape("Did you mean 'pr_hit'?")):
        azgym.make_localizer("ransac:pr_hti=0.99")


def test_hyperparameters_are_keyword_only():
    with pytest.raises(TypeError):
        Ransac(0.01)


def test_keywords_reach_the_localizer():
    localizer = azgym.make_localizer("ransac", weighted=True, max_iter=7)
    params = localizer.get_params()
    assert params["weighted"] is True and params["max_iter"] == 7
    assert params["pr_hit"] == 0.999  # defaults untouched


def plugin_file(tmp_path):
    path = tmp_path / f"plugin_{uuid.uuid4().hex[:8]}.py"
    path.write_text(PLUGIN_SOURCE, encoding="utf-8")
    return path


def check_plugin_works(localizer, beacons):
    assert isinstance(localizer, Localizer)
    assert localizer.get_params() == {"max_iter": 9, "tag": "x"}
    estimate = localizer.localize(ideal_frame(1.0, -2.0, 0.4, beacons), beacons)
    assert estimate.ok
    assert math.hypot(estimate.x - 1.0, estimate.y + 2.0) < 1e-8
    assert localizer.calls == 1


def test_file_spec_loads_a_plugin(tmp_path, paper_beacons):
    path = plugin_file(tmp_path)
    localizer = azgym.make_localizer(f"{path}:Wrapped", max_iter=9, tag="x")
    check_plugin_works(localizer, paper_beacons)
    # Loading the same file again gives the same class (the module is imported once).
    assert type(azgym.make_localizer(f"{path}:Wrapped")) is type(localizer)
    check_plugin_works(azgym.make_localizer(f"{path}:Wrapped:max_iter=9,tag=x"), paper_beacons)


def test_module_spec_loads_a_plugin(tmp_path, monkeypatch, paper_beacons):
    path = plugin_file(tmp_path)
    monkeypatch.syspath_prepend(str(tmp_path))
    localizer = azgym.make_localizer(f"{path.stem}:Wrapped", max_iter=9, tag="x")
    check_plugin_works(localizer, paper_beacons)
    assert type(localizer).__module__ == path.stem


def test_module_spec_of_a_builtin_class():
    assert type(azgym.make_localizer("azgym.localize.lsq:LeastSquares")) is LeastSquares


@pytest.mark.parametrize(
    ("spec", "message"),
    [
        ("azgym.localize.lsq:NoSuchClass", "has no attribute 'NoSuchClass'"),
        ("no_such_module_for_azgym_tests:Foo", "cannot import 'no_such_module_for_azgym_tests'"),
        ("/no/such/dir/plugin.py:Foo", "no file"),
    ],
)
def test_bad_specs_raise_invalid_input(spec, message):
    with pytest.raises(InvalidInputError, match=re.escape(message)):
        azgym.make_localizer(spec)


def test_a_factory_without_localize_is_rejected(tmp_path):
    path = plugin_file(tmp_path)
    with pytest.raises(InvalidInputError, match=re.escape(
            "names a function, not a localizer class (a class with a localize(measurements, "
            "beacons) method)")):
        azgym.make_localizer(f"{path}:not_a_localizer")


def test_a_bad_keyword_for_a_plugin(tmp_path):
    path = plugin_file(tmp_path)
    with pytest.raises(InvalidInputError, match=re.escape(
            "unknown hyperparameter 'max_itr'. Did you mean 'max_iter'? Valid hyperparameters: "
            "max_iter, tag.")):
        azgym.make_localizer(f"{path}:Wrapped", max_itr=1)


def test_a_factory_taking_any_keyword_reports_its_own_error(clean_registry):
    def picky(**params):
        raise TypeError(f"picky takes nothing, got {sorted(params)}")

    azgym.register_localizer("picky", picky)
    with pytest.raises(InvalidInputError, match=re.escape("localizer 'picky': picky takes")):
        azgym.make_localizer("picky:anything=1")


SPECS = [
    ("ransac", "ransac", {}),
    ("ransac:weighted=true", "ransac", {"weighted": True}),
    ("ransac: max_iter = 7 ,weighted=True", "ransac", {"max_iter": 7, "weighted": True}),
    ("ransac-weighted", "ransac", {"weighted": True}),
    ("ransac-weighted:weighted=false", "ransac", {"weighted": False}),
    ("mex-coarse:n_candidates=4", "mex", {"coarse_step": 0.1, "n_candidates": 4}),
    ("mex:bounds=null,step=2e-2", "mex", {"bounds": None, "step": 0.02}),
    ("path/to/mine.py:Mine", "path/to/mine.py:Mine", {}),
    ('path/to/mine.py:Mine:tag=fast,note="a, b",n="3"', "path/to/mine.py:Mine",
     {"tag": "fast", "note": "a, b", "n": "3"}),
    (r"C:\dir\mine.py:Mine:x=-1.5", r"C:\dir\mine.py:Mine", {"x": -1.5}),
    ("pkg.module:Mine:flag=None", "pkg.module:Mine", {"flag": None}),
]


@pytest.mark.parametrize(("spec", "target", "params"), SPECS, ids=[s for s, _, _ in SPECS])
def test_a_spec_reads_its_target_and_hyperparameters_and_its_label_reads_back(spec, target,
                                                                              params):
    assert registry.parse_spec(spec) == (target, params)
    label = registry.spec_label(target, params)
    assert registry.parse_spec(label) == (target, params)
    assert registry.spec_label(*registry.parse_spec(label)) == label


def test_a_label_is_canonical_and_a_preset_name_where_one_matches():
    assert registry.spec_label("ransac", {"weighted": True}) == "ransac-weighted"
    assert registry.spec_label("ransac", {"weighted": 1}) == "ransac:weighted=1"
    assert registry.spec_label("mex", {"coarse_step": 0.1}) == "mex-coarse"
    assert registry.spec_label("ransac", {"weighted": True, "max_iter": 7}) == \
        "ransac:max_iter=7,weighted=true"
    assert registry.spec_label("m.py:M", {"tag": "fast", "n": "3", "s": "a,b"}) == \
        'm.py:M:n="3",s="a,b",tag=fast'


def test_a_list_of_numbers_is_written_with_commas_and_read_back():
    target, params = registry.parse_spec("mex:bounds=0,-2.5,12,8e0,step=0.05")
    assert (target, params) == ("mex", {"bounds": [0, -2.5, 12, 8.0], "step": 0.05})
    label = registry.spec_label(target, params)
    assert label == "mex:bounds=0,-2.5,12,8.0,step=0.05"
    assert registry.parse_spec(label) == (target, params)
    assert registry.spec_label("m.py:M", {"s": "a,b"}) == 'm.py:M:s="a,b"'  # a string: quoted


@pytest.mark.parametrize(("spec", "message"), [
    ("ransac:weighted", "'ransac' is a registered name; its hyperparameters are written "
                        "ransac:NAME=VALUE"),
    ("ransac:weighted=", "cannot read hyperparameters from 'weighted='"),
    ("ransac:weighted=true,", "a comma with nothing after it"),
    ("ransac:max_iter=1,max_iter=2", "hyperparameter 'max_iter' twice"),
    ("mex:bounds=[0,0,1,1]", "bounds must be a scalar"),
    ('m.py:M:tag="open', 'tag="open is not a valid quoted string'),
])
def test_a_malformed_spec_is_refused_with_what_is_wrong(spec, message):
    with pytest.raises(InvalidInputError, match=re.escape(message)):
        azgym.make_localizer(spec)


def test_spec_hyperparameters_build_the_localizer_and_clash_with_keywords():
    assert azgym.make_localizer("ransac-weighted").get_params()["weighted"] is True
    mex = azgym.make_localizer("mex-coarse:step=0.02")
    assert (mex.coarse_step, mex.step) == (0.1, 0.02)
    assert azgym.make_localizer("ransac:max_iter=7", weighted=True).get_params()["max_iter"] == 7
    with pytest.raises(InvalidInputError, match=re.escape(
            "hyperparameter 'max_iter' given both in the spec and as a keyword")):
        azgym.make_localizer("ransac:max_iter=7", max_iter=8)


def test_presets_are_listed_and_their_names_taken(clean_registry):
    assert {"ransac-weighted", "mex-coarse"} <= set(azgym.list_localizers())
    with pytest.raises(InvalidInputError, match="already registered"):
        azgym.register_localizer("mex-coarse", Mex)


def test_register_a_factory(clean_registry, paper_beacons):
    azgym.register_localizer("lsq-light", lambda **kw: LeastSquares(max_iter=5, **kw))
    assert "lsq-light" in azgym.list_localizers()
    localizer = azgym.make_localizer("lsq-light", weighted=True)
    assert localizer.get_params()["max_iter"] == 5 and localizer.get_params()["weighted"]
    estimate = localizer.localize(ideal_frame(2.0, 3.0, -1.0, paper_beacons), paper_beacons)
    assert estimate.ok and math.hypot(estimate.x - 2.0, estimate.y - 3.0) < 1e-8


def test_register_a_taken_name_raises(clean_registry):
    with pytest.raises(InvalidInputError, match=re.escape("'ransac' is already registered")):
        azgym.register_localizer("ransac", LeastSquares)
    azgym.register_localizer("mine", LeastSquares)
    with pytest.raises(InvalidInputError, match=re.escape("'mine' is already registered")):
        azgym.register_localizer("mine", Triplet)
    assert type(azgym.make_localizer("mine")) is LeastSquares  # the first one stays


@pytest.mark.parametrize("name", ["", None, 5])
def test_register_needs_a_name(clean_registry, name):
    with pytest.raises(InvalidInputError, match=re.escape("non-empty string")):
        azgym.register_localizer(name, LeastSquares)


def test_registrations_do_not_leak_between_tests():
    assert "mine" not in azgym.list_localizers()
    assert "lsq-light" not in azgym.list_localizers()


@pytest.mark.parametrize(
    "localizer",
    [
        Ransac(),
        Ransac(weighted=True, pr_hit=0.95, random_state=3, delta_alpha_d=0.01),
        Mex(step=0.02, bounds=(-1.0, -2.0, 3.0, 4.0), coarse_step=0.1),
        LeaveOneOut(z_max=1e-4, k_min=5),
        LeastSquares(coverage=False),
        Triplet(degeneracy_tol=1e-6),
    ],
    ids=repr,
)
def test_repr_round_trips_the_parameters(localizer):
    namespace = {cls.__name__: cls for cls in BUILTINS.values()}
    rebuilt = eval(repr(localizer), namespace)  # noqa: S307 - repr of our own objects
    assert type(rebuilt) is type(localizer)
    assert rebuilt.get_params() == localizer.get_params()
    assert repr(rebuilt) == repr(localizer)


def test_get_params_lists_every_keyword_unchanged():
    bounds = (0.0, 0.0, 1.0, 1.0)
    mex = Mex(step=0.5, bounds=bounds)
    assert mex.get_params() == {"step": 0.5, "bounds": bounds, "coarse_step": None,
                                "n_candidates": 8, "margin": 5.0}
    assert mex.get_params()["bounds"] is bounds  # stored as given, not converted
    assert repr(Triplet()) == "Triplet(degeneracy_tol=0.01)"


def test_hyperparameters_are_validated_when_built_and_again_after_a_change(paper_beacons):
    with pytest.raises(InvalidInputError, match=re.escape("Ransac.pr_hit")):
        Ransac(pr_hit=2.0)
    localizer = Ransac()
    localizer.pr_hit = 2.0
    frame = ideal_frame(0.0, 0.0, 0.0, paper_beacons)
    with pytest.raises(InvalidInputError, match=re.escape("Ransac.pr_hit")):
        localizer.localize(frame, paper_beacons)
    localizer.pr_hit = 0.99
    assert localizer.localize(frame, paper_beacons).ok
    # Changing a parameter after a successful call is validated again.
    localizer.max_iter = 0
    with pytest.raises(InvalidInputError, match=re.escape("Ransac.max_iter")):
        localizer.localize(frame, paper_beacons)


def test_random_state_generator_is_kept_as_given():
    rng = np.random.default_rng(0)
    assert Ransac(random_state=rng).get_params()["random_state"] is rng


def test_entry_point_plugins_are_listed_and_built(monkeypatch):
    from importlib.metadata import EntryPoint

    import azgym.registry
    from azgym.localize import registry

    plugin = EntryPoint(name="vendor-lsq", value="azgym.localize.lsq:LeastSquares",
                        group=registry.ENTRY_POINT_GROUP)

    def fake_entry_points(*, group):
        return [plugin] if group == registry.ENTRY_POINT_GROUP else []

    monkeypatch.setattr(azgym.registry, "entry_points", fake_entry_points)
    assert "vendor-lsq" in azgym.list_localizers()
    localizer = azgym.make_localizer("vendor-lsq", max_iter=7)
    assert type(localizer).__name__ == "LeastSquares" and localizer.max_iter == 7
    with pytest.raises(azgym.UnknownNameError, match=re.escape("Did you mean 'vendor-lsq'?")):
        azgym.make_localizer("vendor-lsk")


def test_a_plugin_never_shadows_a_built_in_and_a_registration_is_no_built_in(clean_registry,
                                                                            monkeypatch):
    from importlib.metadata import EntryPoint

    import azgym.registry

    plugin = EntryPoint(name="tkf", value="azgym.localize.lsq:LeastSquares",
                        group=registry.ENTRY_POINT_GROUP)
    monkeypatch.setattr(azgym.registry, "entry_points", lambda *, group: [plugin] if group ==
                        registry.ENTRY_POINT_GROUP else [])
    assert registry.resolve("tkf").__name__ == "Tkf"  # the built-in tracker, not the plug-in
    azgym.register_localizer("mine", LeastSquares)
    assert registry.is_builtin("ransac") and not registry.is_builtin("mine")


@pytest.mark.parametrize(("ok", "x", "message"), [("True", 0.4, "ok is a bool"),
                                                 (True, float("nan"), "finite pose")])
def test_check_localizer_refuses_a_string_ok_or_an_ok_without_a_finite_pose(ok, x, message):
    from azgym.core import Estimate

    class Liar:
        def localize(self, measurements, beacons):
            return Estimate(x, -0.7, 0.3, np.ones(len(measurements), dtype=bool), ok=ok)

    with pytest.raises(azgym.LocalizerCheckError, match=message):
        azgym.check_localizer(Liar())


@pytest.mark.parametrize("spec", ["os:system", "subprocess:Popen", "builtins:eval",
                                  "azgym.localize.ransac:n_trials"])
def test_a_spec_that_is_not_a_localizer_class_is_refused_before_it_is_called(spec, tmp_path,
                                                                              monkeypatch):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(InvalidInputError, match="not a localizer class"):
        azgym.make_localizer(spec, command="touch pwned", args="touch pwned", shell=True)
    assert not (tmp_path / "pwned").exists()


def test_check_localizer_says_what_it_checked_when_everything_passes(capsys):
    azgym.check_localizer(azgym.make_localizer("lsq"))
    printed = capsys.readouterr().out
    assert printed.startswith("check_localizer: LeastSquares passed all 7 checks:")
    assert "noise-free recovery of 3 poses" in printed and "permutation invariance" in printed
    azgym.check_localizer(azgym.make_localizer("lsq"), verbose=False)
    assert capsys.readouterr().out == ""
