"""
A rosbag2 (MCAP, Jazzy's default storage) that stays whole when writing fails.

Written with the ``rosbags`` library (rosbag2 format version 9, as Jazzy's
``ros2 bag record`` writes it): ``metadata.yaml`` with each topic's type,
offered QoS profiles and RIHS01 type hash, and one ``.mcap`` file in the
``ros2`` profile (schemas in ``ros2msg``, CDR messages, each channel's
``offered_qos_profiles`` and ``topic_type_hash``).  ``ros2 bag info`` and
``ros2 bag play`` read it; ``play`` re-latches the topics whose publishers
offered transient local.

What is kept when something goes wrong:

* messages are written to the file in chunks, at the latest every
  :data:`FLUSH_PERIOD_S` (:meth:`SessionBagWriter.flush`), so a crash loses at
  most that much;
* a write that fails (disk full, a quota, an I/O error) truncates the file to
  the end of the last whole chunk, frees :data:`RESERVE_BYTES` set aside in
  the bag's folder at the start, and closes the bag (its index and
  ``metadata.yaml``) with every message written before: one line
  (:attr:`SessionBagWriter.problem`) says what happened and what was kept;
  later messages are refused;
* a path that cannot be made (no permission, a file in the way, an existing
  bag) is refused before anything is recorded (:class:`BagError`, one line).
"""

from collections import defaultdict
from io import BytesIO
import os
from pathlib import Path
from typing import Dict, Optional, Sequence

from rosbags.interfaces import Connection, Qos
from rosbags.rosbag2 import StoragePlugin, Writer, WriterError
from rosbags.rosbag2.storage_mcap import (Channel, McapWriter, PendingChunk, write_channel,
                                          write_string)
from rosbags.typesys import get_types_from_msg, get_typestore, Stores

#: The longest time a message waits in memory before it is in the file, s.
FLUSH_PERIOD_S = 1.0
#: Space set aside at the start so that a full disk still leaves room for the index.
RESERVE_BYTES = 1 << 20
#: The file that holds that space while the bag is open (removed when it closes).
RESERVE_NAME = '.session_record.reserve'
#: The rosbag2 format version Jazzy writes.
BAG_VERSION = 9


class BagError(RuntimeError):
    """The bag cannot be made or written; the message is one line for the user."""


def _reason(error: BaseException) -> str:
    return (getattr(error, 'strerror', None) or str(error)).splitlines()[0]


class _WholeWrites:
    """
    The MCAP file without a user-space buffer: each write is whole or raises OSError.

    So that the file's length is known after every chunk (the point to return to
    when a later write fails), and no short write passes unnoticed.
    """

    def __init__(self, buffered) -> None:
        buffered.flush()
        self._file = buffered
        self._fd = buffered.fileno()

    def write(self, data) -> int:
        view = memoryview(data).cast('B')
        total = len(view)
        while len(view):
            view = view[os.write(self._fd, view):]
        return total

    def tell(self) -> int:
        return os.lseek(self._fd, 0, os.SEEK_CUR)

    def truncate(self, size: int) -> None:
        os.ftruncate(self._fd, size)
        os.lseek(self._fd, size, os.SEEK_SET)

    def close(self) -> None:
        self._file.close()


class _Ros2McapWriter(McapWriter):
    """rosbags' MCAP storage, plus Jazzy's ``topic_type_hash`` in each channel's metadata."""

    def __init__(self, path: Path, compression) -> None:
        super().__init__(path, compression)
        self.bio = _WholeWrites(self.bio)

    def add_connection(self, connection: Connection, offered_qos_profiles: str) -> None:
        metadata = BytesIO()
        for key, value in (('offered_qos_profiles', offered_qos_profiles),
                           ('topic_type_hash', connection.digest)):
            write_string(metadata, key)
            write_string(metadata, value)
        self.channels.append(Channel(connection.id, connection.msgtype, connection.topic,
                                     connection.ext.serialization_format, metadata.getvalue()))
        self.channel_stats[connection.id] = 0
        write_channel(self.chunk.bio, self.channels[-1], self.schemas)


class _Writer(Writer):
    STORAGE_PLUGINS = {StoragePlugin.MCAP: _Ros2McapWriter}


def concatenated_definition(msgtype: str, definitions: Dict[str, str]) -> str:
    """Return rosbag2's concatenated ``ros2msg`` schema: the type's fields, then each nested."""
    parts = [definitions[msgtype].rstrip('\n')]
    for name, text in definitions.items():
        if name != msgtype:
            parts.append('=' * 80 + f'\nMSG: {name}\n' + text.rstrip('\n'))
    return '\n'.join(parts) + '\n'


class SessionBagWriter:
    """
    One rosbag2 being recorded: topics added as they appear, raw CDR messages written.

    :ivar path: the bag's folder.
    :ivar problem: '' while all is well; else the one line that says why writing
        stopped and what the bag holds.
    :ivar counts: messages written per topic (those in the file or its pending chunk).
    """

    def __init__(self, path, extra_types: Optional[Dict[str, str]] = None) -> None:
        """
        Create the bag's folder and file, and set aside the reserve.

        :raises BagError: the folder exists or cannot be made, or the disk is full.
        """
        self.path = Path(path)
        self.problem = ''
        self.closed = False
        self.counts: Dict[str, int] = defaultdict(int)
        self._connections: Dict[str, Connection] = {}
        self._typestore = get_typestore(Stores.ROS2_JAZZY)
        if extra_types:
            self.add_types(extra_types)
        self._writer = None
        try:
            self._writer = _Writer(self.path, version=BAG_VERSION,
                                   storage_plugin=StoragePlugin.MCAP)
            self._writer.open()
            self._reserve = self.path / RESERVE_NAME
            with open(self._reserve, 'wb') as stream:
                stream.write(b'\0' * RESERVE_BYTES)
        except WriterError as error:
            raise BagError(f'cannot record into {self.path}: {_reason(error)}') from None
        except OSError as error:
            self._discard()
            raise BagError(f'cannot record into {self.path}: {_reason(error)}') from None
        self._kept_end = 0   # the last message stamp that is in the file, ns
        self._chunks = 0

    @property
    def storage(self) -> _Ros2McapWriter:
        """Return the MCAP file being written (rosbags' writer of it)."""
        return self._writer.storage

    def add_types(self, definitions: Dict[str, str]) -> None:
        """Teach the writer message types it does not know (``{type: .msg text}``)."""
        types = {}
        for name, text in definitions.items():
            if name not in self._typestore.fielddefs:
                types.update(get_types_from_msg(text, name))
        if types:
            self._typestore.register(types)

    def knows(self, msgtype: str) -> bool:
        """Tell whether the writer has the definition of ``msgtype``."""
        return msgtype in self._typestore.fielddefs

    def add_topic(self, topic: str, msgtype: str, offered_qos: Sequence[Qos],
                  type_hash: str = '', definitions: Optional[Dict[str, str]] = None) -> None:
        """
        Add a topic (once; a topic already added is left as it is).

        :param offered_qos: the publishers' QoS profiles (``rosbags.interfaces.Qos``).
        :param type_hash: the publishers' RIHS01 hash (``RIHS01_<hex>``); '' = the
            hash of the writer's definition.
        :param definitions: ``{type: .msg text}`` of the type and what it nests (from its
            class), for a schema rosbags cannot write itself (an action's feedback).
        """
        if topic in self._connections or self.problem or self.closed:
            return
        rihs01 = type_hash or self._typestore.hash_rihs01(msgtype)
        try:
            msgdef, _ = self._typestore.generate_msgdef(msgtype, ros_version=2)
        except (AssertionError, KeyError):   # rosbags writes msg/ types only
            if not definitions or msgtype not in definitions:
                raise
            msgdef = concatenated_definition(msgtype, definitions)
        self._connections[topic] = self._writer.add_connection(
            topic, msgtype, msgdef=msgdef, rihs01=rihs01, offered_qos_profiles=offered_qos)
        self.counts[topic] += 0

    def has_topic(self, topic: str) -> bool:
        """Tell whether ``topic`` was added."""
        return topic in self._connections

    def write(self, topic: str, stamp_ns: int, data) -> bool:
        """
        Write one serialized message; return False when the bag no longer takes any.

        A failing write closes the bag with what was written before (module doc).
        """
        if self.problem or self.closed:
            return False
        kept = self.storage.bio.tell()
        try:
            self._writer.write(self._connections[topic], int(stamp_ns), data)
        except OSError as error:
            self._writer.counts[self._connections[topic].id] += 1   # undone with the chunk
            self._fail(error, kept)
            return False
        self.counts[topic] += 1
        self._note_chunks()
        return True

    def flush(self) -> bool:
        """Put the pending messages into the file (a chunk); return False if writing failed."""
        if self.problem or self.closed or not self.storage.chunk.bio.tell():
            return not self.problem
        kept = self.storage.bio.tell()
        try:
            self.storage.close_chunk()
        except OSError as error:
            self._fail(error, kept)
            return False
        self._note_chunks()
        return True

    def _note_chunks(self) -> None:
        if len(self.storage.chunks) != self._chunks:
            self._chunks = len(self.storage.chunks)
            self._kept_end = self.storage.message_end_time

    def _fail(self, error: OSError, kept: int) -> None:
        """Drop the chunk that could not be written, free the reserve, close what was kept."""
        storage = self.storage
        lost = 0
        for connection_id, messages in storage.chunk.msgs.items():
            storage.channel_stats[connection_id] -= len(messages)
            self._writer.counts[connection_id] -= len(messages)
            lost += len(messages)
        for topic, connection in self._connections.items():
            self.counts[topic] = self._writer.counts[connection.id]
        storage.chunk = PendingChunk(2**63 - 1, 0, BytesIO(), defaultdict(list))
        storage.message_end_time = self._writer.max_timestamp = self._kept_end
        if not self._chunks:
            storage.message_start_time = self._writer.min_timestamp = self._kept_end
        kept_count = sum(self.counts.values())
        try:
            storage.bio.truncate(kept)
            self._free_reserve()
            self._writer.close()
            self.closed = True
            what = f'the bag is closed with the {kept_count} messages written before'
        except OSError as again:
            self._writer.abort()
            self.closed = True
            what = (f'the {kept_count} messages written before are in {storage.path.name} '
                    f'but its index could not be written ({_reason(again)}): '
                    f'`ros2 bag reindex {self.path}` rebuilds it')
        self.problem = (f'writing {self.path} failed ({_reason(error)}): {what}; '
                        f'{lost} messages not yet written are lost')

    def _free_reserve(self) -> None:
        try:
            os.remove(self._reserve)
        except OSError:
            pass

    def _discard(self) -> None:
        """Remove what ``open`` made (nothing was recorded)."""
        try:
            if self._writer is not None:
                self._writer.abort()
        except OSError:
            pass

    def close(self) -> str:
        """Close the bag (index, ``metadata.yaml``); return :attr:`problem` ('' when whole)."""
        if self.closed:
            return self.problem
        self.flush()
        if not self.closed:
            kept = self.storage.bio.tell()
            try:
                self._free_reserve()
                self._writer.close()
            except OSError as error:
                if self._writer.storage is None:   # the file is whole; metadata.yaml is not
                    self.problem = (f'writing {self.path}/metadata.yaml failed '
                                    f'({_reason(error)}): the messages are in the .mcap file; '
                                    f'`ros2 bag reindex {self.path}` writes it again')
                else:
                    self._fail(error, kept)
            self.closed = True
        return self.problem
