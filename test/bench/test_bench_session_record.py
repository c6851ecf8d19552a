"""bench.session_record, small: every message kept at 1200 Hz, the reference and the target."""

from bench import run_all, session_record


def test_the_section_is_registered():
    assert run_all.REGISTRY['session_record'] == 'bench.session_record'


def test_a_short_run_records_every_message_and_names_its_reference_and_target():
    section = session_record.run(quick=True, seconds=1.0)
    assert set(section) == set(session_record.CASES)
    per_sample = section['per_sample']
    assert per_sample['messages_per_s'] == 1200.0
    # Nothing lost: every message published is in the closed bag.
    assert per_sample['sent'] > 0 and per_sample['lost'] == 0
    assert per_sample['reference_received'] == per_sample['reference_sent']
    assert per_sample['cpu_percent'] > 0 and per_sample['reference_cpu_percent'] > 0
    assert per_sample['target'] == 'none lost, <= 25 % of a core'
    assert isinstance(per_sample['meets_target'], bool)
    assert section['chunks_12']['lost'] == 0
