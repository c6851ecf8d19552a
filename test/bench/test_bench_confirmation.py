"""bench/confirmation.py: wrong goals after the confirmation step, on real recorded gaze."""

import numpy as np
import pytest

from bench import confirmation
from eye_bci_ros2.recordings import find_data

REAL = find_data('real_gaze')


@pytest.mark.skipif(REAL is None, reason='no real gaze recordings (../shared/data/real_gaze)')
def test_the_confirmation_step_on_real_gaze(capsys):
    assert confirmation.main([]) == 0
    printed = capsys.readouterr().out
    assert 'menu layout' in printed and 'wrong goals per first choice' in printed
    result = confirmation.run()
    for row in result['layouts'].values():
        # Every jump of the dot gave a round, and most were answered 'back' (looked at).
        assert row['rounds'] > 200 and row['back'] > 0.9 * row['rounds']
        assert row['go'] + row['back'] + row['none'] == row['rounds']
        # The confirmation can only lower the wrong-goal rate of the first choice.
        assert row['wrong_goal_bound'] < result['first']['wrong %'] / 100.0


def test_rounds_put_back_on_the_dot_and_go_beside_it():
    class Targets:
        jumps = True
        places = np.array([[500.0, 400.0], [960.0, 540.0], [60.0, 540.0]])
        onsets = np.array([0.0, 1.0, 2.0])

        def __len__(self):
            return len(self.places)

    class Screen:
        width_px, height_px = 1920, 1080

    class Recording:
        targets, screen = Targets(), Screen()

    rounds = list(confirmation.confirm_rounds(Recording(), lambda r, p: 300.0,
                                              np.random.default_rng(0)))
    assert [start for start, _ in rounds] == [1.0, 2.0]
    for (start, centres), dot in zip(rounds, Targets.places[1:]):
        np.testing.assert_allclose(centres[1], dot)                 # 'back' on the dot
        assert abs(abs(centres[0, 0] - dot[0]) - 300.0) < 1e-9     # 'go' 300 px beside it
    assert rounds[1][1][0, 0] == 360.0      # the side that keeps 'go' on the screen
