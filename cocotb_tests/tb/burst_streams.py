"""The cocotb side of the transaction-level bench (``pgs_kernel_burst_tb.sv``): whole bursts in, whole bursts and
trace batches out, with no Python activity per cycle or per beat.

* :class:`BurstSource` writes up to ``BURST`` beats at once into an ``axis_burst_source`` (one wide value) and
  wakes again only when the source has loaded them (``<prefix>_taken_seq`` changes);
* :class:`BurstSink` collects the bursts of an ``axis_burst_sink`` (it wakes when ``<prefix>_burst_seq`` changes);
* :class:`TraceBatches` hands every batch of ``trace_batcher`` records (each stamped with its retire cycle) to a
  callback as raw bytes.

The burst buffers and batches are read and written in the time step in which their sequence number changes,
before the next clock edge; a sequence number that moves by more than one between two wake-ups (a lost burst or
batch) raises.
"""

from __future__ import annotations

from typing import Any, Callable

from cocotb.triggers import FallingEdge, ValueChange

from cocotb_tests.tb.axis_words import Gate


def _int(handle: Any) -> int:
    return int(handle.value)


def _handles(dut: Any, prefix: str, *names: str) -> list[Any]:
    return [getattr(dut, f"{prefix}_{name}") for name in names]


class BurstSource:
    """Drives one ``axis_burst_source`` of the bench: ``<prefix>_burst_data/_last/_beats/_seq`` in,
    ``<prefix>_taken_seq`` and ``<prefix>_busy`` out."""

    def __init__(self, dut: Any, prefix: str, beat_bytes: int, burst: int):
        self.data, self.last, self.beats, self.seq_in, self.taken, self.busy = _handles(
            dut, prefix, "burst_data", "burst_last", "burst_beats", "burst_seq", "taken_seq", "busy")
        self.beat_bytes, self.burst = beat_bytes, burst
        self.seq = 0
        self.seq_in.value = 0
        self.bursts_sent = 0

    async def _slot_free(self) -> None:
        while _int(self.taken) != self.seq:
            await ValueChange(self.taken)

    async def send(self, data: bytes, aborted: Gate) -> bool:
        """Send ``data`` (whole beats; TLAST on the last) a burst at a time and wait until its last beat has been
        taken; False when ``aborted`` (a DMA reset) became true meanwhile (the bursts already queued still go)."""
        if len(data) % self.beat_bytes:
            raise ValueError(f"{len(data)} bytes are not a whole number of {self.beat_bytes}-byte beats")
        n = len(data) // self.beat_bytes
        step = self.burst * self.beat_bytes
        for start in range(0, n, self.burst):
            await self._slot_free()
            if aborted():
                return False
            beats = min(self.burst, n - start)
            self.data.value = int.from_bytes(data[start * self.beat_bytes:start * self.beat_bytes + step], "little")
            self.last.value = 1 << (beats - 1) if start + beats == n else 0
            self.beats.value = beats
            self.seq = (self.seq + 1) & 0xFFFFFFFF
            self.seq_in.value = self.seq
            self.bursts_sent += 1
        await self._slot_free()
        while _int(self.busy):
            await FallingEdge(self.busy)
        return not aborted()


class BurstSink:
    """Drains one ``axis_burst_sink`` of the bench: ``<prefix>_enable/_limit`` in, ``<prefix>_burst_data/_beats/
    _last/_seq`` out."""

    def __init__(self, dut: Any, prefix: str, beat_bytes: int, burst: int):
        self.enable, self.limit, self.data, self.beats, self.last, self.seq = _handles(
            dut, prefix, "enable", "limit", "burst_data", "burst_beats", "burst_last", "burst_seq")
        self.beat_bytes, self.burst = beat_bytes, burst
        self.enable.value = 0

    async def recv_packet(self, max_beats: int, aborted: Gate) -> tuple[bytes, int, bool]:
        """Take beats until TLAST or ``max_beats``; returns (bytes, beats, ended_with_tlast)."""
        out = bytearray()
        got = 0
        seen = _int(self.seq)
        self.limit.value = max_beats
        self.enable.value = 1
        try:
            while True:
                await ValueChange(self.seq)
                if aborted():
                    return bytes(out), got, False
                seq = _int(self.seq)
                if seq != (seen + 1) & 0xFFFFFFFF:
                    raise AssertionError(f"S2MM burst buffer: burst {seen + 1} lost (now at {seq})")
                seen = seq
                beats = _int(self.beats)
                out += _int(self.data).to_bytes(self.burst * self.beat_bytes, "little")[:beats * self.beat_bytes]
                got += beats
                if _int(self.last) or got >= max_beats:
                    return bytes(out), got, bool(_int(self.last))
        finally:
            self.enable.value = 0


class TraceBatches:
    """Reads the bench's trace batches (``trace_batch``, ``trace_fill``, ``trace_batch_seq``) and passes each to
    ``consume(raw, records)``: ``records`` records of ``record_bytes`` bytes each, back to back."""

    def __init__(self, dut: Any, record_bytes: int, batch: int, consume: Callable[[bytes, int], None]):
        self.batch_h, self.fill_h, self.seq_h = dut.trace_batch, dut.trace_fill, dut.trace_batch_seq
        self.record_bytes, self.batch = record_bytes, batch
        self.consume = consume
        self.batches = 0

    def _raw(self, records: int) -> bytes:
        return _int(self.batch_h).to_bytes(self.batch * self.record_bytes, "little")[:records * self.record_bytes]

    async def monitor(self) -> None:
        """Hand over every full batch as it closes (runs until cancelled or ``consume`` raises)."""
        while True:
            await ValueChange(self.seq_h)
            seq = _int(self.seq_h)
            if seq != (self.batches + 1) & 0xFFFFFFFF:
                raise AssertionError(f"trace batch {self.batches + 1} lost (the bench is at batch {seq})")
            self.batches += 1
            self.consume(self._raw(self.batch), self.batch)

    def flush(self) -> None:
        """Hand over the records of the batch still open (at the end of the run)."""
        fill = _int(self.fill_h)
        if fill:
            self.consume(self._raw(fill), fill)
