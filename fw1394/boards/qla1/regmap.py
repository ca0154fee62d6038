"""The QLA1 register map as data (docs/boards/qla1.md prints these tables).

Numbers come from :mod:`fw1394.boards.qla1.regs`; this module adds what each
register is: access, power-up value, what a read and a write do, and how an
offset reaches it over FireWire and over Ethernet.
"""

from __future__ import annotations

from fw1394.boards.qla1.config_rom import (
    CSR_BYTE_MASK,
    CSR_WINDOW_PREFIX,
    CSR_WINDOW_SHIFT,
    NODE_IDS,
    ROM_BASE,
    SPLIT_TIMEOUT_HI,
    SPLIT_TIMEOUT_LO,
    STATE_CLEAR,
    STATE_SET,
)
from fw1394.boards.qla1.regs import (
    CHANNELS,
    HUB_BOARD_INFO,
    HUB_LAST_WRITE,
    HUB_MEMORY_BASE,
    HUB_MEMORY_QUADLETS,
    HUB_QUADLETS_WRITTEN,
    HUB_QUERY,
    PROM_BUFFER_BASE,
    QLA1_HARDWARE_VERSION,
    QLA_PROM_BUFFER,
    QLA_PROM_COMMAND,
    QLA_PROM_RESULT,
    REGISTER_INDEX_MASK,
)
from fw1394.boards.qla1.regs import (
    BoardRegister as B,
)
from fw1394.boards.qla1.regs import (
    ChannelRegister as C,
)
from fw1394.boards.regmap import (
    ETHERNET,
    FIREWIRE,
    Decoding,
    Group,
    IgnoredBits,
    Register,
    RegisterMap,
    Window,
)

CSR_WINDOW = Window(CSR_WINDOW_PREFIX << CSR_WINDOW_SHIFT, CSR_BYTE_MASK + 1)
#: The MAIN space (offset bits 15..12 = 0) looks at bits 7..4 (channel) and 3..0
#: (register) only: bits 11..8 alias, so 0x104 is register 4 (FPGA1394V3.v:255,
#: QLA.v:94-96).
MAIN_SPACE_IGNORES = IgnoredBits(mask=0x0F00, when_mask=0xF000, when_value=0x0000)
#: Over FireWire the link decodes the CSR window itself; everything else reaches
#: the register bus as offset bits 15..0, a quadlet index (FireWire.v:981-984).
FIREWIRE_DECODING = Decoding(
    kept=REGISTER_INDEX_MASK, ignored=(MAIN_SPACE_IGNORES,), windows=(CSR_WINDOW,)
)
#: Over Ethernet only offset bits 15..0 reach the register bus (EthernetIO.v:1249):
#: no CSR window, so 0xFFFF_F000_0400 is register space there (MAIN 0x400 = STATUS).
ETHERNET_DECODING = Decoding(kept=REGISTER_INDEX_MASK, ignored=(MAIN_SPACE_IGNORES,))

BOARD = Group(
    "board",
    (
        Register(
            "STATUS",
            B.STATUS,
            "rw",
            None,
            "see below; power-up value `0x40000000 \\| board << 24`",
            "masked commands, never stored (see below)",
        ),
        Register(
            "FW_PHY_REQ",
            B.FW_PHY_REQ,
            "rw",
            0,
            "last value written (low 16 bits)",
            "starts a PHY access (see PHY)",
            bits=16,
        ),
        Register(
            "FW_PHY_RESP",
            B.FW_PHY_RESP,
            "rw",
            0,
            "`register << 8 \\| value` of the last PHY read",
            "stores the low 16 bits",
            bits=16,
        ),
        Register(
            "WATCHDOG",
            B.WATCHDOG,
            "rw",
            0x1680,
            "`led << 31 \\| period`; power-up period 0x1680",
            "bit 31 LED mode, bits 15..0 period",
        ),
        Register(
            "HARDWARE_VERSION",
            B.HARDWARE_VERSION,
            "ro",
            QLA1_HARDWARE_VERSION,
            "0x514C4131 'QLA1'",
            "ignored",
        ),
        Register(
            "TEMPERATURE",
            B.TEMPERATURE,
            "ro",
            0x3C3C,
            "0x3C3C (two amplifier temperatures, raw)",
            "ignored",
            label="TEMP",
            bits=16,
        ),
        Register(
            "DIGITAL_OUTPUT",
            B.DIGITAL_OUTPUT,
            "rw",
            0,
            "4 output bits",
            "bits 11..8 mask bits 3..0",
            label="DIGOUT",
            bits=4,
        ),
        Register("FIRMWARE_VERSION", B.FIRMWARE_VERSION, "ro", None, "`firmware`", "ignored"),
        Register(
            "PROM_STATUS",
            B.PROM_STATUS,
            "rw",
            0,
            "interface status: 0 (every command done at once)",
            "M25P16 command: instruction in 31..24, address in 23..0",
        ),
        Register(
            "PROM_RESULT",
            B.PROM_RESULT,
            "ro",
            0,
            "result of the last PROM command (ID, status, quadlets read or written)",
            "ignored",
        ),
        Register(
            "DIGITAL_INPUT",
            B.DIGITAL_INPUT,
            "ro",
            None,
            "DOUT mirrored in 15..12, bit 28 = motor supply on; no switch or encoder line active",
            "ignored",
            label="DIGIN",
        ),
        Register(
            "IP_ADDRESS",
            B.IP_ADDRESS,
            "rw",
            None,
            "byte-reversed IP (127.0.0.1 → 0x0100007F), 0xFFFFFFFF unassigned; 0 on FPGA V1",
            "stored; firmware ≥ 9 adds the board id to bits 31..24",
            label="IP_ADDR",
        ),
        Register(
            "ETH_STATUS",
            B.ETH_STATUS,
            "ro",
            None,
            "V1 0x00000000, V2 0x80000000, V3 0x40B00000",
            "ignored (no error flags to clear)",
        ),
        Register(
            "DALLAS_STATUS",
            B.DALLAS_STATUS,
            "rw",
            None,
            "firmware ≥ 7: DS2505 status (enabled, reset answered, family 0x0B once read)",
            "`address << 16 \\| 2` reads 256 bytes into 0x6000, `3` the next 256",
        ),
        Register("IO_EXPANDER", B.IO_EXPANDER, "ro", 0, "0", "ignored"),
        Register(
            "GIT_DESCRIPTION",
            B.GIT_DESCRIPTION,
            "ro",
            0,
            "`git_description` (default 0)",
            "ignored",
            label="GIT_DESC",
        ),
    ),
)

CHANNEL = Group(
    "channel",
    (
        Register(
            "ADC",
            C.ADC,
            "ro",
            None,
            "`pot << 16 \\| current`; pot = 0x8000 + 0x100·channel; current = DAC command "
            "while the amplifier is on, else 0x8000",
        ),
        Register(
            "DAC",
            C.DAC,
            "rw",
            0x8000,
            "last command (bits 15..0), power-up 0x8000",
            "stored only with bit 31 (valid); firmware ≥ 8: bit 29 masks bit 28 = amplifier enable",
        ),
        Register(
            "ENCODER_PRELOAD",
            C.ENCODER_PRELOAD,
            "rw",
            None,
            "last preload",
            "sets preload and position (24 bits)",
            label="ENC_LOAD",
        ),
        Register(
            "ENCODER_POSITION",
            C.ENCODER_POSITION,
            "ro",
            0x800000,
            "position, power-up 0x800000 (midrange); overflow and A/B/I bits 0",
            label="ENC_DATA",
        ),
        Register(
            "ENCODER_PERIOD",
            C.ENCODER_PERIOD,
            "ro",
            None,
            "stalled encoder: 0x80000000 (firmware ≥ 6 overflow bit), 0x8000 before",
            label="PERIOD",
        ),
        Register("ENCODER_QTR1", C.ENCODER_QTR1, "ro", 0, "0", label="QTR1"),
        Register(
            "DOUT_CONTROL", C.DOUT_CONTROL, "rw", 0, "last value", "stored", label="DOUT_CTRL"
        ),
        Register("ENCODER_QTR5", C.ENCODER_QTR5, "ro", 0, "0", label="QTR5"),
        Register("ENCODER_RUNNING", C.ENCODER_RUNNING, "ro", 0, "0", label="RUN"),
        Register(
            "MOTOR_CONFIG",
            C.MOTOR_CONFIG,
            "rw",
            None,
            "bit 24 current control available, 23..16 enable delay, 15..0 current limit (0xFFFF)",
            "bit 24 set → limit from 15..0; bit 25 set → delay from 23..16",
            label="MOTOR_CONFIG (fw ≥ 8)",
        ),
        Register(
            "MOTOR_STATUS",
            C.MOTOR_STATUS,
            "ro",
            None,
            "bit 29 amplifier on, bit 28 enable requested",
            label="MOTOR_STATUS (fw ≥ 8)",
        ),
    ),
    copies=range(1, CHANNELS + 1),
    stride=0x10,
)

HUB = Group(
    "hub",
    (
        Register(
            "HUB_MEMORY",
            HUB_MEMORY_BASE,
            "ro",
            None,
            "the boards' real-time blocks of the last broadcast query",
            "a block write is another board's contribution",
            count=HUB_MEMORY_QUADLETS,
        ),
        Register(
            "HUB_QUERY",
            HUB_QUERY,
            "rw",
            None,
            "`{sequence, mask}`",
            "`(sequence << 16) \\| board_mask` starts a broadcast read",
        ),
        Register(
            "HUB_LAST_WRITE",
            HUB_LAST_WRITE,
            "ro",
            None,
            "`{index of the last quadlet written, quadlets in use}`",
        ),
        Register("HUB_QUADLETS_WRITTEN", HUB_QUADLETS_WRITTEN, "ro", None, "quadlets in use"),
        Register(
            "HUB_BOARD_INFO",
            HUB_BOARD_INFO,
            "ro",
            None,
            "`{board id in 19..16, mask of lower-numbered boards}`",
        ),
    ),
)

PROM = Group(
    "prom",
    (
        Register(
            "PROM_PAGE_BUFFER",
            PROM_BUFFER_BASE,
            "rw",
            None,
            "the 256 bytes the last read-data command fetched",
            "block write {page-program command, data} programs a page",
            count=64,
        ),
        Register(
            "QLA_PROM_COMMAND",
            QLA_PROM_COMMAND,
            "wo",
            None,
            "0",
            "25AA128 command: read/write byte, read/write block, write enable, status",
        ),
        Register("QLA_PROM_RESULT", QLA_PROM_RESULT, "ro", 0, "last byte or status read"),
        Register(
            "QLA_PROM_BUFFER",
            QLA_PROM_BUFFER,
            "rw",
            None,
            "quadlets of the last block read",
            "quadlets for the next block write",
            count=16,
        ),
    ),
)

DALLAS = Group(
    "dallas",
    (
        Register(
            "DALLAS_BUFFER",
            0x6000,
            "ro",
            None,
            "firmware ≥ 7: the 256 bytes of the DS2505 the last control word fetched",
            count=64,
        ),
    ),
)

ETHERNET_PHYS = Group(
    "ethernet",
    (
        Register(
            "ETH_SWITCH_DATA",
            0x40A0,
            "ro",
            None,
            "firmware ≥ 9, FPGA V3: the switch's status block, 'ESW0' first (0 before)",
            count=32,
        ),
        Register(
            "MDIO_PHY1",
            0x41A0,
            "rw",
            0,
            "`{busy 26..24 (0), last register 20..16, its data 15..0}`",
            "clause-22 frame: start, operation (10 read, 01 write), PHY address, register, data",
            label="MDIO (PHY1, FPGA V3)",
        ),
        Register(
            "MDIO_PHY2",
            0x42A0,
            "rw",
            0,
            "as PHY1",
            "as PHY1",
            label="MDIO (PHY2, FPGA V3)",
        ),
    ),
)

CSR = Group(
    "csr",
    (
        Register("STATE_CLEAR", STATE_CLEAR, "rw", None, "state bits 31..2", "clears bits"),
        Register("STATE_SET", STATE_SET, "rw", None, "state bits 31..2", "sets bits"),
        Register("NODE_IDS", NODE_IDS, "rw", None, "`{bus 0x3FF, node}`", "sets the bus id"),
        Register("SPLIT_TIMEOUT_HI", SPLIT_TIMEOUT_HI, "rw", 0, "seconds"),
        Register("SPLIT_TIMEOUT_LO", SPLIT_TIMEOUT_LO, "rw", None, "800 times 125 µs at power-up"),
        Register(
            "CONFIG_ROM", ROM_BASE, "ro", None, "bus-info block, root directory, leaves", count=256
        ),
    ),
    base=CSR_WINDOW.base,
    quadlet_index=False,
)

REGISTER_MAP = RegisterMap(
    "qla1",
    (BOARD, CHANNEL, HUB, PROM, DALLAS, ETHERNET_PHYS, CSR),
    decodings={FIREWIRE: FIREWIRE_DECODING, ETHERNET: ETHERNET_DECODING},
    probe="HARDWARE_VERSION",
)
