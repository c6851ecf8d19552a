"""
Which LSL stream is the EEG amplifier's: the EEG stream profile of the LSL connection.

The decoder (:mod:`eye_bci_ros2.nodes.ssvep_decoder`) reads its stream through
:class:`eye_bci_ros2.streams.lsl_connection.StreamConnection`, as the gaze bridge
does; the stream is selected by the layout's type and name
(:mod:`eye_bci_ros2.ssvep.layouts`) and the parameters.  The channels are not
a reason to refuse a stream here: the decoder chooses them after connecting
and says which are missing (:func:`eye_bci_ros2.ssvep.layouts.resolve_channels`);
a stream whose type says it is no EEG (an eye tracker's gaze, markers) is refused
(:mod:`eye_bci_ros2.streams.content_types`).
"""

from typing import Any, Mapping, Optional

from eye_bci_ros2.ssvep.layouts import ANY, LAYOUTS, stream_name_matches
from eye_bci_ros2.streams.content_types import not_eeg
from eye_bci_ros2.streams.lsl_connection import StreamDescription


def _literal(value: str) -> Optional[str]:
    """Quote ``value`` as an XPath literal; None when it holds both quote characters."""
    if "'" not in value:
        return f"'{value}'"
    if '"' not in value:
        return f'"{value}"'
    return None


class EegStreamProfile:
    """The decoder's ``layout``, ``stream_type``, ``stream_name`` and ``source_id``."""

    kind = 'EEG'

    def __init__(self, values: Mapping[str, Any]):
        """Select streams by the decoder's parameter values."""
        self.layout = LAYOUTS[values['layout']]
        self.stream_type = values.get('stream_type') or self.layout.stream_type
        self.stream_name = values.get('stream_name') or ''
        self.source_id = values.get('source_id') or ''

    def predicate(self) -> str:
        """Return the XPath of type and source_id (names are checked after resolving)."""
        terms = []
        for key, value in (('type', self.stream_type if self.stream_type != ANY else ''),
                           ('source_id', self.source_id if self.source_id != ANY else '')):
            literal = _literal(value) if value else None
            if literal is not None:
                terms.append(f'{key}={literal}')
        return ' and '.join(terms)

    def matches(self, stream: StreamDescription) -> bool:
        """Tell whether type, name and source_id are the selected ones."""
        return ((self.stream_type == ANY or stream.stream_type == self.stream_type)
                and stream_name_matches(self.layout, stream.name, self.stream_name)
                and (self.source_id in ('', ANY) or stream.source_id == self.source_id))

    def misfit(self, stream: StreamDescription) -> Optional[str]:
        """Say why a matching stream is no EEG (its type; None: it is taken, channels later)."""
        return not_eeg(stream.stream_type)

    def unusable(self, stream: StreamDescription) -> Optional[str]:
        """Say why a stream is no EEG whatever the parameters (gaze, markers; None: it may be)."""
        return not_eeg(stream.stream_type)

    def describe(self) -> str:
        """Say which streams are selected."""
        parts = [f"layout '{self.layout.name}'"]
        if self.stream_type != ANY:
            parts.append(f"type '{self.stream_type}'")
        name = self.stream_name or self.layout.stream_name
        if name != ANY:
            prefix = self.layout.name_is_prefix and not self.stream_name
            parts.append(f"name {'starting with ' if prefix else ''}'{name}'")
        if self.source_id not in ('', ANY):
            parts.append(f"source_id '{self.source_id}'")
        return ', '.join(parts)

    def how_to_select(self, stream: StreamDescription) -> str:
        """Say which parameters would select ``stream``."""
        settings = []
        if self.stream_type != ANY and stream.stream_type != self.stream_type:
            settings.append(f"stream_type:='{stream.stream_type}'")
        if not stream_name_matches(self.layout, stream.name, self.stream_name):
            settings.append(f"stream_name:='{stream.name}'")
        if self.source_id not in ('', ANY) and stream.source_id != self.source_id:
            settings.append(f"source_id:='{stream.source_id}'")
        return ' '.join(settings) or 'nothing (it matches)'
