"""One declaration per setting: the dataclass checks and the parameter rows agree."""

import math

import pytest

from eye_bci_ros2.base.settings import declarations, Setting
from eye_bci_ros2.base.validators import in_interval, Interval
from eye_bci_ros2.decision.feedback import FeedbackSettings
from eye_bci_ros2.decision.fusion import FusionSettings
from eye_bci_ros2.decision.rounds import ArbiterSettings, RULE_FIELDS

SETTINGS_CLASSES = (ArbiterSettings, FusionSettings, FeedbackSettings)


def outside(interval: Interval):
    """Numbers just outside each finite end (an open end itself included)."""
    values = []
    if math.isfinite(interval.low):
        values.append(interval.low if interval.low_open else interval.low - 1e-6)
    if math.isfinite(interval.high):
        values.append(interval.high if interval.high_open else interval.high + 1e-6)
    return values


@pytest.mark.parametrize('cls', SETTINGS_CLASSES)
def test_every_field_is_declared_once_with_its_default(cls):
    defaults = cls()
    for setting in declarations(cls):
        assert setting.description and setting.name
        assert getattr(defaults, setting.name) == setting.default


@pytest.mark.parametrize('cls', SETTINGS_CLASSES)
def test_a_value_outside_the_declared_range_is_refused_naming_the_setting(cls):
    checked = 0
    for setting in declarations(cls):
        if setting.interval is None:
            continue
        for value in outside(setting.interval):
            with pytest.raises(ValueError, match=setting.name):
                cls(**{setting.name: type(setting.default)(value)
                       if isinstance(setting.default, float) else value})
            checked += 1
    assert checked >= 2


def test_the_python_settings_refuse_what_the_node_parameter_refuses():
    # Before, the dataclass took dwell_s 20 s and stall_timeout_s 100 s that the node's
    # parameters refused: a bench or script could run settings no node can.
    for name, value in (('dwell_s', 20.0), ('stall_timeout_s', 100.0), ('reorder_s', 3.0),
                        ('min_samples', 200000), ('screen_width_mm', 5.0)):
        with pytest.raises(ValueError, match=name):
            ArbiterSettings(**{name: value})


def test_confidence_is_refused_with_one_reason_everywhere():
    with pytest.raises(ValueError) as from_settings:
        ArbiterSettings(confidence=1.0)
    with pytest.raises(ValueError) as from_the_rules:
        ArbiterSettings().evidence(0.0).add([[0.0, 0.0]], [0.0], None, 1.0)
    assert str(from_settings.value) == str(from_the_rules.value)
    assert '(0.5, 1)' in str(from_settings.value)


def test_the_rule_fields_are_the_ones_declared_as_rule():
    assert set(RULE_FIELDS) == {
        'classification', 'accuracy_deg', 'precision_deg', 'k_sigma', 'ratio', 'size_aware',
        'min_share', 'screen_width_mm', 'screen_height_mm', 'viewing_distance_mm',
        'screen_width', 'screen_height', 'urgent_label', 'second_look_labels',
        'second_look_dwell_s'}


def test_a_declaration_refuses_a_default_that_breaks_it():
    with pytest.raises(ValueError, match='default'):
        Setting(2.0, 'a share', interval=Interval(0.0, 1.0))


def test_intervals_read_as_written():
    assert str(Interval(0.5, 1.0, low_open=True, high_open=True)) == '(0.5, 1)'
    assert str(Interval(0.0, 60.0, low_open=True)) == '(0, 60]'
    assert str(Interval(0.0)) == '>= 0'
    assert Interval(0.0, 1.0, low_open=True).closure == (0.0, 1.0)
    assert Interval(0.0).closure is None
    assert in_interval(math.nan, Interval(0.0, 1.0))
    assert in_interval(True, Interval(0.0, 1.0)), 'true is no number'
    assert in_interval(0.5, Interval(0.0, 1.0)) is None
    reason = in_interval(0.0, Interval(0.0, 60.0, low_open=True), 's', 'the window')
    assert reason == 'must be in (0, 60] s, got 0.0: the window'
