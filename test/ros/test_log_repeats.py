"""QuietRepeats: a line repeated with other numbers is logged once, then summed up."""

from eye_bci_ros2.ros.log_throttle import QuietRepeats


class Logger:
    """Records what would be logged, by level (stands in for an rclpy logger)."""

    def __init__(self):
        self.lines = []

    def info(self, text):
        self.lines.append(('info', text))

    def debug(self, text):
        self.lines.append(('debug', text))


def test_a_cycle_of_rounds_without_a_choice_is_logged_once_then_summed_up():
    logger, now = Logger(), [0.0]
    quiet = QuietRepeats(logger, period_s=30.0, clock=lambda: now[0])
    for round_number in range(1, 41):           # 40 rounds, 1.5 s each: 60 s
        quiet.info(f'round {round_number} (request): offered [a, b], window 1.0 s')
        quiet.info('no choice (no sample in any region) by mean: 0 samples')
        now[0] += 1.5
    shown = [text for level, text in logger.lines if level == 'info']
    assert shown[:2] == ['round 1 (request): offered [a, b], window 1.0 s',
                         'no choice (no sample in any region) by mean: 0 samples']
    summaries = [text for text in shown[2:] if 'repeated' in text]
    assert len(shown) == 2 + len(summaries) and len(summaries) == 1   # at 30 s; 60 s not yet
    assert sum(level == 'debug' for level, _ in logger.lines) == 78  # nothing lost


def test_a_choice_ends_the_run_so_the_next_round_is_shown():
    logger = Logger()
    quiet = QuietRepeats(logger, clock=lambda: 0.0)
    assert quiet.info('round 1 (request): offered [a]')
    assert not quiet.info('round 2 (request): offered [a]')
    quiet.reset()
    assert quiet.info("choice 'a' by mean: 50 samples")
    assert quiet.info('round 3 (request): offered [a]')


def test_no_choice_lines_that_differ_only_in_the_option_named_are_one_kind():
    # Issue 39: while the person looked around without choosing, the menu logged an INFO
    # "no choice (...): asking again" every second until the 30 s summary: the reasons name
    # the option looked at, and every option made a kind of its own.
    logger, now = Logger(), [0.0]
    quiet = QuietRepeats(logger, period_s=30.0, clock=lambda: now[0])
    reasons = ["the fixation at ({x}, 388) px is not clearly on one option ('{o}' posterior "
               '0.{x})', "the gaze rested on '{o}' from the round start: look away and back to "
               'choose it', "the gaze rested near '{o}' from the round start: look away and "
               'back to choose it', 'the fixation at ({x}, 900) px is on no option',
               'no fixation of 0.15 s', 'no valid gaze sample']
    options = ['kitchen', 'bedroom', 'bathroom', 'living_room']
    for round_number in range(29):                 # one round a second, under 30 s
        reason = reasons[round_number % len(reasons)].format(
            o=options[round_number % len(options)], x=400 + round_number)
        quiet.info(f'no choice ({reason}): asking again')
        now[0] += 1.0
    shown = [text for level, text in logger.lines if level == 'info']
    assert len(shown) == len(reasons), shown                  # one line per kind of reason
