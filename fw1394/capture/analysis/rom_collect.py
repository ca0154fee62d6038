"""Configuration ROM quadlets gathered from the read transactions of a trace."""

from __future__ import annotations

import numpy as np

from fw1394.capture.analysis.csr import CONFIG_ROM, CONFIG_ROM_END, CSR_BASE
from fw1394.capture.analysis.rom_decode import RomReport, decode_rom
from fw1394.capture.analysis.transactions import Transactions
from fw1394.capture.formats.batch import Batch
from fw1394.packets import LAYOUTS, RCode, TCode

#: ROMs kept at most (one per node and generation): bounds memory on long traces.
MAX_ROMS = 256
_BLOCK_HEADER = LAYOUTS[TCode.read_block_response].header_size


class RomCollector:
    """Quadlets read from each node's ROM, per (node ID, generation)."""

    def __init__(self) -> None:
        self.roms: dict[tuple[int, int], dict[int, int]] = {}

    def add(self, tx: Transactions, batch: Batch) -> None:
        offset = tx["offset"]
        first, end = CSR_BASE + CONFIG_ROM, CSR_BASE + CONFIG_ROM_END
        rows = np.flatnonzero(
            (offset >= first)
            & (offset < end)
            & (tx["rcode"] == RCode.resp_complete)
            & (tx["resp_bidx"] >= 0)
        )
        if not len(rows):
            return
        tcode, responder, generation = tx["tcode"], tx["responder"], tx["generation"]
        for row in rows.tolist():
            key = (int(responder[row]), int(generation[row]))
            if key not in self.roms and len(self.roms) >= MAX_ROMS:
                continue
            quadlets = self.roms.setdefault(key, {})
            address = int(offset[row]) - CSR_BASE
            answer = int(tx["resp_tcode"][row])
            if tcode[row] == TCode.read_quadlet_request:
                if answer == TCode.read_quadlet_response and tx["resp_quadlet"][row] >= 0:
                    quadlets[address] = int(tx["resp_quadlet"][row])
            elif tcode[row] == TCode.read_block_request and answer == TCode.read_block_response:
                length = int(tx["resp_data_length"][row])
                self._block(quadlets, address, batch, int(tx["resp_bidx"][row]), length)

    @staticmethod
    def _block(quadlets: dict[int, int], address: int, batch: Batch, row: int, length: int) -> None:
        packet = batch.packet(row)
        header = _BLOCK_HEADER + (4 if batch.flag("crc_present")[row] else 0)
        data = packet[header : header + max(length, 0)]
        for index in range(len(data) // 4):
            quadlets[address + 4 * index] = int.from_bytes(data[4 * index : 4 * index + 4], "big")

    def reports(self) -> list[tuple[int, int, RomReport]]:
        return [
            (node, generation, decode_rom(quadlets))
            for (node, generation), quadlets in sorted(self.roms.items())
        ]
