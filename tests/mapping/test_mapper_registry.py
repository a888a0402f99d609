"""The mapper registry: names, specs, plug-ins, profiles, and hyperparameters refused by name."""

from __future__ import annotations

import math
import re
import textwrap
from importlib.metadata import EntryPoint

import pytest

import azgym
import azgym.registry
from azgym.errors import InvalidInputError, UnknownNameError
from azgym.mapping import MapAnswer, SupportsSurvey, list_mappers, make_mapper
from azgym.mapping import registry as mapper_registry
from azgym.mapping.mappers import PriorMapper, RaysMapper, RepairMapper, SurveyMapper
from azgym.profile import MotionProfile, Profile, SensorProfile, VehicleProfile

BUILTINS = {"survey": SurveyMapper, "rays": RaysMapper, "prior": PriorMapper,
            "repair": RepairMapper}

PLUGIN = textwrap.dedent('''
    """A plug-in mapper for the registry tests: places nothing, counts its calls."""

    import numpy as np

    from azgym.mapping import MapAnswer, Mapper


    class Counting(Mapper):
        name = "counting"

        def __init__(self, *, steps=3, delta_alpha_d=0.01):
            self.steps = steps
            self.delta_alpha_d = delta_alpha_d
            self.calls = 0
            self._validate_once()

        def _survey(self, drive, prior):
            self.calls += 1
            return MapAnswer(np.zeros(0, np.int64), np.zeros((0, 2)), np.zeros((0, 2, 2)))


    def not_a_mapper():
        return 42
''')


def plugin_file(tmp_path):
    path = tmp_path / "counting_mapper.py"
    path.write_text(PLUGIN)
    return path


def test_the_built_ins_are_listed_and_build_their_class():
    assert list_mappers() == sorted(BUILTINS)
    assert set(mapper_registry.DEFAULT_MAPPERS) == set(BUILTINS)
    for name, cls in BUILTINS.items():
        mapper = make_mapper(name)
        assert type(mapper) is cls and mapper.name == name
        assert isinstance(mapper, SupportsSurvey)
    assert azgym.make_mapper is make_mapper and azgym.list_mappers() == list_mappers()


def test_an_unknown_name_suggests_the_closest():
    with pytest.raises(UnknownNameError, match=re.escape(
            "unknown mapper 'surve'. Did you mean 'survey'? Valid mappers: prior, rays, repair, "
            "survey.")):
        make_mapper("surve")


def test_spec_hyperparameters_reach_the_mapper():
    mapper = make_mapper("survey:loss=huber,loss_scale=2.5")
    assert mapper.get_params()["loss"] == "huber" and mapper.get_params()["loss_scale"] == 2.5
    assert make_mapper("repair:repair_span=0.5").get_params()["repair_span"] == 0.5


@pytest.mark.parametrize(("spec", "message"), [
    ("survey:los=huber", "mapper 'survey': unknown hyperparameter 'los'. Did you mean 'loss'?"),
    ("rays:loss=huber", "mapper 'rays': unknown hyperparameter 'loss'."),
    ("prior:anything=1", "mapper 'prior': unknown hyperparameter 'anything'."),
    ("survey:loss=l2", "SurveyMapper.loss must be one of ('cauchy', 'huber'), got 'l2'"),
    ("survey:speed_noise=-1", "SurveyMapper.speed_noise must be"),
    ("survey:loss_scale=abc", "SurveyMapper.loss_scale must be a finite number, got 'abc'"),
    ("rays:wheelbase=0", "RaysMapper.wheelbase must be > 0, got 0"),
    ("rays:coverage=maybe", "RaysMapper.coverage must be True or False"),
    ("rays:vehicle=bicycle", "RaysMapper.vehicle must be one of"),
    ("repair:repair_span=3", "Robust.repair_span must be"),
    ("survey:loss=[1]", "mapper spec 'survey:loss=[1]': loss must be a scalar"),
    ("survey:Thing", "mapper spec 'survey:Thing': 'survey' is a registered name; its "
                     "hyperparameters are written survey:NAME=VALUE"),
])
def test_a_bad_hyperparameter_or_spec_is_refused_by_name(spec, message):
    with pytest.raises(InvalidInputError, match=re.escape(message)):
        make_mapper(spec)


def test_a_hyperparameter_set_later_is_checked_before_the_next_survey():
    from azgym.mapping.checks import ANCHORS, line_drive, world
    from azgym.mapping.problem import Prior

    mapper = make_mapper("rays")
    mapper.extra_sigma = -1.0
    with pytest.raises(InvalidInputError, match=re.escape("RaysMapper.extra_sigma must be")):
        mapper.survey(line_drive(world(), seconds=1.0), Prior(world(), ANCHORS))


def test_a_profile_sets_the_hyperparameters_the_spec_leaves_out():
    profile = Profile(VehicleProfile(kind="differential-drive", camera_ahead=0.1),
                      SensorProfile(delta_alpha_d=0.01, field_of_view=1.2),
                      MotionProfile(speed_noise=0.05, speed_factor=1.1))
    params = make_mapper("survey:delta_alpha_d=0.02", profile).get_params()
    assert params["vehicle"] == "differential-drive" and params["camera_ahead"] == 0.1
    assert params["speed_noise"] == 0.05 and params["speed_factor"] == 1.1
    assert params["delta_alpha_d"] == 0.02  # the spec's own wins
    assert make_mapper("repair", profile).get_params()["vehicle"] == "differential-drive"
    assert make_mapper("prior", profile).get_params() == {}  # takes none of them
    assert make_mapper("rays", Profile()).get_params() == make_mapper("rays").get_params()


def test_a_plugin_file_is_loaded_with_its_hyperparameters_and_a_profile(tmp_path):
    path = plugin_file(tmp_path)
    mapper = make_mapper(f"{path}:Counting:steps=5")
    assert type(mapper).__name__ == "Counting" and mapper.get_params() == {
        "steps": 5, "delta_alpha_d": 0.01}
    assert type(make_mapper(f"{path}:Counting")) is type(mapper)  # imported once
    profiled = make_mapper(f"{path}:Counting", Profile(sensor=SensorProfile(delta_alpha_d=0.03)))
    assert profiled.get_params()["delta_alpha_d"] == 0.03
    with pytest.raises(InvalidInputError, match=re.escape(
            "unknown hyperparameter 'step'. Did you mean 'steps'?")):
        make_mapper(f"{path}:Counting:step=5")


@pytest.mark.parametrize(("attribute", "message"), [
    ("not_a_mapper", "names a function, not a mapper class (a class with a survey(drive, prior) "
                     "method)"),
    ("Missing", "has no attribute 'Missing'"),
])
def test_a_plugin_file_that_names_no_mapper_class_is_refused(tmp_path, attribute, message):
    with pytest.raises(InvalidInputError, match=re.escape(message)):
        make_mapper(f"{plugin_file(tmp_path)}:{attribute}")


def test_a_missing_file_or_module_is_named():
    with pytest.raises(InvalidInputError, match=re.escape("mapper spec '/no/such/m.py:M': no "
                                                          "file")):
        make_mapper("/no/such/m.py:M")
    with pytest.raises(InvalidInputError, match=re.escape("cannot import 'no_such_mapper_mod'")):
        make_mapper("no_such_mapper_mod:M")


@pytest.mark.parametrize("spec", ["os:system", "subprocess:Popen", "builtins:eval",
                                  "azgym.localize.ransac:Ransac"])
def test_a_spec_that_is_not_a_mapper_class_is_refused_before_it_is_called(spec, tmp_path,
                                                                           monkeypatch):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(InvalidInputError, match="not a mapper class"):
        make_mapper(f"{spec}:args=touch pwned,shell=true")
    assert not (tmp_path / "pwned").exists()


def test_entry_point_plugins_are_listed_and_built(monkeypatch):
    plugin = EntryPoint(name="vendor-prior", value="azgym.mapping.mappers:PriorMapper",
                        group=mapper_registry.ENTRY_POINT_GROUP)
    bad = EntryPoint(name="vendor-bad", value="azgym.localize.lsq:LeastSquares",
                     group=mapper_registry.ENTRY_POINT_GROUP)
    monkeypatch.setattr(azgym.registry, "entry_points", lambda *, group: [plugin, bad] if group ==
                        mapper_registry.ENTRY_POINT_GROUP else [])
    assert {"vendor-prior", "vendor-bad"} <= set(list_mappers())
    assert type(make_mapper("vendor-prior")) is PriorMapper
    with pytest.raises(InvalidInputError, match="not a mapper class"):
        make_mapper("vendor-bad")
    with pytest.raises(UnknownNameError, match=re.escape("Did you mean 'vendor-prior'?")):
        make_mapper("vendor-prio")


def test_a_spec_names_a_mapper_or_not():
    assert mapper_registry.is_mapper_spec("survey:loss=huber")
    assert mapper_registry.is_mapper_spec("azgym.mapping.mappers:RaysMapper")
    assert not mapper_registry.is_mapper_spec("ransac:weighted=true")
    assert not mapper_registry.is_mapper_spec("azgym.localize.lsq:LeastSquares")


def test_the_repr_round_trips_and_the_answer_type_is_public():
    mapper = make_mapper("survey:loss=huber")
    assert eval(repr(mapper), {"SurveyMapper": SurveyMapper}).get_params() == mapper.get_params()
    assert azgym.MapAnswer is MapAnswer and not math.isnan(mapper.get_params()["loss_scale"])
