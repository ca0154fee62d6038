`timescale 1ns/1ps
// The 1394 link of the 2010 snake-robot FPGA (thesis sections 5.3 and 6.1),
// written for fw1394 from the thesis and the 1394a PHY-link interface.
//
// It receives every packet the PHY delivers, checks the header CRC (and the
// data CRC of block writes), drops damaged packets and packets for other nodes
// silently, and serves quadlet and block reads and writes through a register
// bus: reads are concatenated (ack_pending ended with Hold, then the response
// after the PHY grants the bus again, the serial bus never released), writes
// are unified (ack_complete). Every packet ends with Hold or Idle and one more
// Idle before the link releases CTL and D. The node's physical ID comes
// from PHY register 0, which the link asks for after reset and which the PHY
// also sends after every bus reset.
//
// Bit conventions inside: ctl[1] is CTL0 and ctl[0] CTL1, so 2'b10 is
// Receive/Transmit; d[7] is D0, so bytes are in their natural order.
//
// Speeds: a packet comes at S100 (two bits a cycle on D0-D1), S200 (four on
// D0-D3) or S400 (a byte), as its speed code says; the ack and the response go
// out at the same speed, asked for in the ImmReq.
//
// Planted defects (for fuzzing the fuzzer), each a `define:
//   FW1394_DEFECT_NO_HEADER_CRC   the header CRC is never compared
//   FW1394_DEFECT_ANY_NODE        every destination is taken as this node
//   FW1394_DEFECT_UNBOUNDED_BLOCK blocks longer than MAX_BLOCK are served
//   FW1394_DEFECT_EARLY_ACK       a block write is acked once its header
//                                 checks out, before its data CRC is known
//   FW1394_DEFECT_LONG_HOLD       Hold is kept 60 cycles before a response
//   FW1394_DEFECT_NO_SECOND_GRANT the response follows its ack's Hold at once,
//                                 without waiting for the PHY's second Grant
//   FW1394_DEFECT_NO_CLOSING_IDLE the link releases the interface right after
//                                 the cycle that ends its packet
//   FW1394_DEFECT_BAD_CRC_WRITE   a quadlet write whose header CRC fails is
//                                 performed (and acked ack_data_error)
module fw1394_link #(
    parameter MAX_BLOCK = 2048,
    parameter [9:0] BUS_ID = 10'h3FF
) (
    input  wire        clk,
    input  wire        rst,
    input  wire [1:0]  ctl_i,
    output reg  [1:0]  ctl_o,
    output reg         ctl_oe,
    input  wire [7:0]  d_i,
    output wire [7:0]  d_o,
    output reg         d_oe,
    output reg         lreq,
    output reg  [5:0]  phy_id,
    output reg         phy_id_valid,
    // High while a request is still being served (writes are committed after the ack).
    output wire        busy,
    // Register bus: one strobe per quadlet, read data expected one cycle later.
    output reg  [15:0] reg_addr,
    output reg  [15:0] reg_len,
    output reg         reg_rd,
    output reg         reg_blk_rd,
    output reg         reg_wr,
    output reg         reg_blk_wr,
    output reg  [31:0] reg_wdata,
    input  wire [31:0] reg_rdata
);
`include "fw1394_crc32.vh"

    localparam MAXQ = MAX_BLOCK / 4;
    localparam [1:0] CTL_IDLE = 2'b00, CTL_HOLD = 2'b01, CTL_DATA = 2'b10, CTL_GRANT = 2'b11;
    localparam [1:0] CTL_STATUS = 2'b01;
    localparam [3:0] T_QWRITE = 4'h0, T_BWRITE = 4'h1, T_QREAD = 4'h4, T_BREAD = 4'h5;
    localparam [3:0] T_QREAD_RESP = 4'h6, T_BREAD_RESP = 4'h7;
    localparam [3:0] ACK_COMPLETE = 4'h1, ACK_PENDING = 4'h2, ACK_DATA_ERROR = 4'hD;
    localparam [3:0] RESP_COMPLETE = 4'h0, RESP_DATA_ERROR = 4'h5;
`ifdef FW1394_DEFECT_LONG_HOLD
    localparam HOLD_CYCLES = 60;
`elsif FW1394_DEFECT_NO_SECOND_GRANT
    localparam HOLD_CYCLES = 2;
`else
    localparam HOLD_CYCLES = 1;
`endif

    // ---------------------------------------------------------------- receive
    localparam [2:0] RX_IDLE = 3'd0, RX_DATAON = 3'd1, RX_BYTES = 3'd2, RX_DECIDE = 3'd3,
                     RX_STATUS = 3'd4;
    reg [2:0]  rx_state;
    reg [17:0] bcnt;
    reg [23:0] sh;
    reg [31:0] hcrc, dcrc;
    reg [3:0]  tcode;
    reg [15:0] dest, src, index, len;
    reg [5:0]  tl;
    reg [31:0] qdata;
    reg        hdr_ok, data_ok;
    reg [31:0] wbuf [0:MAXQ-1];
    reg [15:0] st_bits;
    reg [3:0]  st_n;
    reg        need_id;

    // Receive speed (0 S100, 1 S200, 2 S400) and the symbols of the byte under way.
    localparam [1:0] SP100 = 2'd0, SP200 = 2'd1, SP400 = 2'd2;
    reg [1:0]  rx_speed;
    reg [5:0]  rx_acc;
    reg [1:0]  rx_sym;
    wire       rx_last_sym = rx_speed == SP400 || (rx_speed == SP200 && rx_sym == 2'd1)
                          || (rx_speed == SP100 && rx_sym == 2'd3);
    wire [7:0] rx_byte = rx_speed == SP400 ? d_i
                       : rx_speed == SP200 ? {rx_acc[3:0], d_i[7:4]} : {rx_acc, d_i[7:6]};
    wire [7:0]  b = rx_state == RX_BYTES ? rx_byte : d_i;
    wire [31:0] q = {sh, b};
    wire [15:0] bq = bcnt[17:2];
    wire [15:0] ndq = (len + 16'd3) >> 2;
    wire        in_hdr = bcnt < 18'd12 || (bcnt < 18'd16 && tcode != T_QREAD);
    wire [17:0] dbyte = bcnt - 18'd20;
    wire        in_data = tcode == T_BWRITE && bcnt >= 18'd20 && dbyte < {ndq, 2'b00};
    wire [15:0] dq = bq - 16'd5;
`ifdef FW1394_DEFECT_UNBOUNDED_BLOCK
    wire        too_long = 1'b0;
`else
    wire        too_long = (tcode == T_BWRITE || tcode == T_BREAD) && len > MAX_BLOCK;
`endif
    wire [17:0] expected = tcode == T_QREAD ? 18'd16
                         : tcode == T_BWRITE ? 18'd24 + {ndq, 2'b00} : 18'd20;
    wire        supported = tcode == T_QWRITE || tcode == T_BWRITE
                         || tcode == T_QREAD || tcode == T_BREAD;
    wire        broadcast = dest[5:0] == 6'd63;
`ifdef FW1394_DEFECT_ANY_NODE
    wire        mine = phy_id_valid;
`else
    wire        mine = phy_id_valid && (dest[5:0] == phy_id || broadcast);
`endif
`ifdef FW1394_DEFECT_NO_HEADER_CRC
    wire        header_good = 1'b1;
`else
    wire        header_good = hdr_ok;
`endif
    wire        sound = supported && bcnt == expected && header_good
                     && (tcode != T_BWRITE || data_ok);
`ifdef FW1394_DEFECT_EARLY_ACK
    // The ack is decided from the header alone.
    wire        early = tcode == T_BWRITE && header_good && bcnt >= 18'd20 && !too_long;
`else
    wire        early = 1'b0;
`endif
    wire        is_write = tcode == T_QWRITE || tcode == T_BWRITE;
`ifdef FW1394_DEFECT_BAD_CRC_WRITE
    wire        bad_crc_write = tcode == T_QWRITE && bcnt == expected && !header_good;
`else
    wire        bad_crc_write = 1'b0;
`endif

    // ---------------------------------------------------------------- transmit
    localparam [3:0] TX_IDLE = 4'd0, TX_LREQ = 4'd1, TX_WAIT = 4'd2, TX_TURN = 4'd3,
                     TX_TURN2 = 4'd4, TX_ACK = 4'd5, TX_HOLD = 4'd6, TX_PKT = 4'd7,
                     TX_END = 4'd8, TX_CLOSE = 4'd9;
    reg [3:0]  tx_state;
    reg [16:0] lreq_sh;
    reg [4:0]  lreq_n;
    reg        lreq_imm;      // the request under way asks for the bus (else a register read)
    reg [3:0]  ack_code;
    reg        respond;       // a response follows the ack
    reg        second;        // waiting for (or granted) the bus again for the response
    reg [3:0]  resp_tcode, rcode;
    reg [15:0] resp_dest, resp_len, resp_index;
    reg [5:0]  resp_tl;
    reg [15:0] resp_ndq;      // data quadlets sent
    reg [6:0]  hold_n;
`ifdef FW1394_DEFECT_LONG_WRITE_HOLD
    reg [6:0]  ack_hold_n = 7'd0;
`endif
    reg [31:0] tx_q, tx_crc, fetched;
    reg [1:0]  tx_b;
    reg [15:0] tx_qi;         // quadlet of the packet being sent
    reg        tx_block;

    // Write commit, after the ack (the bus is free by then).
    reg        cm_active, cm_block;
    reg [15:0] cm_k, cm_n, cm_index, cm_len;
    reg [31:0] cm_qdata;

    // Transmit speed, and the symbol of tx_byte on D this cycle (S100, S200).
    reg [7:0]  tx_byte;       // the byte being sent
    reg [1:0]  tx_speed;
    reg [1:0]  tx_sym;
    wire       tx_serial = tx_speed != SP400 && ctl_o == CTL_DATA
                        && (tx_state == TX_ACK || tx_state == TX_PKT);
    wire       tx_last_sym = !tx_serial || (tx_speed == SP200 ? tx_sym == 2'd1 : tx_sym == 2'd3);
    wire [7:0] tx_s100 = tx_byte << {tx_sym, 1'b0};
    wire [7:0] tx_s200 = tx_byte << {tx_sym[0], 2'b00};
    assign d_o = !tx_serial ? tx_byte
               : tx_speed == SP200 ? {tx_s200[7:4], 4'h0} : {tx_s100[7:6], 6'h0};

    assign busy = cm_active || tx_state != TX_IDLE || rx_state == RX_DECIDE;

    wire [31:0] crc_now = crc32_byte(tx_crc, tx_byte);
    wire [15:0] last_q = tx_block ? 16'd5 + resp_ndq : 16'd4;
    wire [15:0] node_id = {BUS_ID, phy_id};
    wire        crc_quadlet = tx_qi == 16'd4 || tx_qi == last_q;
    // A CRC quadlet is not part of the CRC that follows it.
    wire [31:0] crc_sent = crc_quadlet ? tx_crc : crc_now;

    // Data quadlet k of a read response, with the bytes past the length zeroed.
    function [31:0] masked;
        input [31:0] value;
        input [15:0] k;
        input [15:0] length;
        reg [17:0] first;
        begin
            first = {k, 2'b00};
            masked = value;
            if (first + 18'd1 >= length) masked[23:0] = 24'h0;
            if (first + 18'd2 >= length) masked[15:0] = 16'h0;
            if (first + 18'd3 >= length) masked[7:0] = 8'h0;
            if (first >= length) masked = 32'h0;
        end
    endfunction

    // Quadlet i of the response: header, header CRC, data, data CRC.
    function [31:0] next_quadlet;
        input [15:0] i;
        begin
            case (i)
                16'd1: next_quadlet = {node_id, rcode, 12'h0};
                16'd2: next_quadlet = 32'h0;
                16'd3: next_quadlet = tx_block ? {resp_len, 16'h0} : fetched;
                16'd4: next_quadlet = ~crc_sent;
                default:
                    if (i - 16'd5 < resp_ndq)
                        next_quadlet = masked(fetched, i - 16'd5, resp_len);
                    else
                        next_quadlet = ~crc_sent;
            endcase
        end
    endfunction

    always @(posedge clk) begin
        if (rst) begin
            rx_state <= RX_IDLE;
            tx_state <= TX_IDLE;
            second <= 1'b0;
            tx_speed <= SP400;
            tx_sym <= 2'd0;
            rx_speed <= SP400;
            rx_sym <= 2'd0;
            phy_id <= 6'd0;
            phy_id_valid <= 1'b0;
            need_id <= 1'b1;
            lreq <= 1'b0;
            lreq_n <= 5'd0;
            cm_active <= 1'b0;
            reg_rd <= 1'b0;
            reg_blk_rd <= 1'b0;
            reg_wr <= 1'b0;
            reg_blk_wr <= 1'b0;
            st_n <= 4'd0;
            ctl_o <= CTL_IDLE;
            ctl_oe <= 1'b0;
            tx_byte <= 8'h00;
            d_oe <= 1'b0;
        end else begin
            reg_rd <= 1'b0;
            reg_blk_rd <= 1'b0;
            reg_wr <= 1'b0;
            reg_blk_wr <= 1'b0;

            // ------------------------------------------------ receive and status
            if (tx_state <= TX_WAIT) begin
                case (rx_state)
                    RX_IDLE: begin
                        if (ctl_i == CTL_DATA && b == 8'hFF) rx_state <= RX_DATAON;
                        else if (ctl_i == CTL_STATUS) begin
                            rx_state <= RX_STATUS;
                            st_bits <= {14'h0, b[7], b[6]};
                            st_n <= 4'd1;
                        end
                    end
                    RX_STATUS: begin
                        if (ctl_i == CTL_STATUS) begin
                            st_bits <= {st_bits[13:0], b[7], b[6]};
                            st_n <= st_n + 4'd1;
                        end else begin
                            // S0..S15: S2 bus reset, S4-S7 register, S8-S15 its value.
                            if (st_n == 4'd8 && st_bits[11:8] == 4'd0) begin
                                phy_id <= st_bits[7:2];
                                phy_id_valid <= 1'b1;
                                need_id <= 1'b0;
                            end else if (st_n == 4'd2 && st_bits[1]) begin
                                phy_id_valid <= 1'b0;
                                need_id <= 1'b1;
                            end
                            st_n <= 4'd0;
                            rx_state <= ctl_i == CTL_DATA && b == 8'hFF ? RX_DATAON : RX_IDLE;
                        end
                    end
                    RX_DATAON: begin
                        if (ctl_i != CTL_DATA) rx_state <= RX_IDLE;   // a null packet
                        else if (b != 8'hFF) begin                   // the speed code
                            rx_state <= RX_BYTES;
                            rx_speed <= b[7:6] == 2'b00 ? SP100 : b[7:4] == 4'b0100 ? SP200
                                                                                   : SP400;
                            rx_sym <= 2'd0;
                            bcnt <= 18'd0;
                            hcrc <= 32'hFFFFFFFF;
                            dcrc <= 32'hFFFFFFFF;
                            hdr_ok <= 1'b0;
                            data_ok <= 1'b0;
                            tcode <= 4'hF;
                            len <= 16'd0;
                        end
                    end
                    RX_BYTES: begin
                        if (ctl_i != CTL_DATA) rx_state <= RX_DECIDE;
                        else if (!rx_last_sym) begin
                            // One more symbol of the byte (S100, S200).
                            rx_acc <= rx_speed == SP200 ? {2'b00, d_i[7:4]}
                                                        : {rx_acc[3:0], d_i[7:6]};
                            rx_sym <= rx_sym + 2'd1;
                        end else begin
                            rx_sym <= 2'd0;
                            if (bcnt != 18'h3FFFF) bcnt <= bcnt + 18'd1;
                            sh <= q[23:0];
                            if (in_hdr) hcrc <= crc32_byte(hcrc, b);
                            if (in_data)
                                dcrc <= crc32_byte(dcrc, dbyte < {2'b00, len} ? b : 8'h00);
                            if (bcnt[1:0] == 2'd3) begin
                                if (bq == 16'd0) begin
                                    dest <= q[31:16];
                                    tl <= q[15:10];
                                    tcode <= q[7:4];
                                end
                                if (bq == 16'd1) src <= q[31:16];
                                if (bq == 16'd2) index <= q[15:0];
                                if (bq == 16'd3) begin
                                    if (tcode == T_QREAD) hdr_ok <= q == ~hcrc;
                                    qdata <= q;
                                    len <= q[31:16];
                                end
                                if (bq == 16'd4 && tcode != T_QREAD) hdr_ok <= q == ~hcrc;
                                if (in_data && (dq < MAXQ || !too_long))
                                    wbuf[dq % MAXQ] <= q;
                                if (tcode == T_BWRITE && bcnt >= 18'd20 && dbyte == {ndq, 2'b11})
                                    data_ok <= q == ~dcrc;
                            end
                        end
                    end
                    RX_DECIDE: begin
                        rx_state <= RX_IDLE;
                        // A packet that comes while the last one is still served is lost.
                        if (mine && (sound || early || bad_crc_write) && tx_state == TX_IDLE
                            && !cm_active) begin
                            if (is_write && !too_long && (sound || bad_crc_write)) begin
                                cm_active <= 1'b1;
                                cm_block <= tcode == T_BWRITE;
                                cm_k <= 16'd0;
                                cm_n <= tcode == T_BWRITE && ndq != 16'd0 ? ndq : 16'd1;
                                cm_index <= index;
                                cm_len <= len;
                                cm_qdata <= qdata;
                            end
                            if (!broadcast) begin
                                tx_state <= TX_LREQ;
                                lreq_imm <= 1'b1;
                                // ImmReq at the packet's speed: start, 000, speed, stop.
                                lreq_sh <= {4'b1000, rx_speed, 2'b00, 9'h0};
                                tx_speed <= rx_speed;
                                lreq_n <= 5'd8;
                                respond <= !is_write;
                                ack_code <= !is_write ? ACK_PENDING
                                          : too_long || bad_crc_write ? ACK_DATA_ERROR
                                          : ACK_COMPLETE;
                                resp_tcode <= tcode == T_QREAD ? T_QREAD_RESP : T_BREAD_RESP;
                                tx_block <= tcode == T_BREAD;
                                rcode <= tcode == T_BREAD && too_long ? RESP_DATA_ERROR
                                                                      : RESP_COMPLETE;
                                resp_dest <= src;
                                resp_tl <= tl;
                                resp_len <= tcode == T_BREAD && !too_long ? len : 16'd0;
                                resp_ndq <= tcode == T_BREAD && !too_long ? ndq : 16'd0;
                                resp_index <= index;
                            end
                        end
                    end
                    default: rx_state <= RX_IDLE;
                endcase
            end

            // ------------------------------------------------ link requests
            if (tx_state == TX_IDLE && need_id && lreq_n == 5'd0 && rx_state == RX_IDLE) begin
                // RdReg of register 0: start, 100, 0000, stop.
                lreq_imm <= 1'b0;
                lreq_sh <= {9'b1_100_0000_0, 8'h0};
                lreq_n <= 5'd9;
                need_id <= 1'b0;
                tx_state <= TX_LREQ;
            end

            // ------------------------------------------------ transmit
            if (!tx_last_sym) tx_sym <= tx_sym + 2'd1;   // the byte's next symbol
            else begin
            tx_sym <= 2'd0;
            case (tx_state)
                TX_LREQ: begin
                    lreq <= lreq_sh[16];
                    lreq_sh <= {lreq_sh[15:0], 1'b0};
                    lreq_n <= lreq_n - 5'd1;
                    if (lreq_n == 5'd1) tx_state <= lreq_imm ? TX_WAIT : TX_IDLE;
                end
                TX_WAIT: begin
                    lreq <= 1'b0;
                    if (ctl_i == CTL_GRANT) tx_state <= TX_TURN;
                end
                TX_TURN: tx_state <= TX_TURN2;
                TX_TURN2: begin
                    ctl_oe <= 1'b1;
                    d_oe <= 1'b1;
                    if (second) begin
                        // Granted again: Hold while the response is set up, then send it.
                        tx_state <= TX_HOLD;
                        ctl_o <= CTL_HOLD;
                        tx_byte <= 8'h00;
                        hold_n <= 7'd0;
`ifdef FW1394_DEFECT_LONG_WRITE_HOLD
                    end else if (is_write && ack_hold_n != 7'd60) begin
                        // Hold before a write's ack, far beyond the 47 cycles allowed.
                        ctl_o <= CTL_HOLD;
                        tx_byte <= 8'h00;
                        ack_hold_n <= ack_hold_n + 7'd1;
`endif
                    end else begin
                        tx_state <= TX_ACK;
                        ctl_o <= CTL_DATA;
                        tx_byte <= {ack_code, ~ack_code};
`ifdef FW1394_DEFECT_LONG_WRITE_HOLD
                        ack_hold_n <= 7'd0;
`endif
                    end
                end
                TX_ACK: begin
                    tx_byte <= 8'h00;
                    if (respond) begin
                        // Hold ends the ack: a concatenation request. The first data
                        // quadlet is read meanwhile.
                        ctl_o <= CTL_HOLD;
                        reg_addr <= resp_index;
                        reg_len <= resp_len;
                        if (!tx_block) reg_rd <= 1'b1;
                        else if (rcode == RESP_COMPLETE) reg_blk_rd <= 1'b1;
`ifdef FW1394_DEFECT_NO_SECOND_GRANT
                        tx_state <= TX_HOLD;
                        hold_n <= 7'd0;
`else
                        tx_state <= TX_CLOSE;
                        second <= 1'b1;
`endif
                    end else begin
                        tx_state <= TX_CLOSE;
                        ctl_o <= CTL_IDLE;
                    end
                end
                TX_CLOSE: begin
                    // One more Idle after the cycle that ended the packet.
                    if (respond && second) fetched <= reg_rdata;
`ifdef FW1394_DEFECT_NO_CLOSING_IDLE
                    tx_state <= TX_IDLE;
                    ctl_oe <= 1'b0;
                    d_oe <= 1'b0;
                    if (second) tx_state <= TX_WAIT;
`else
                    tx_state <= TX_END;
                    ctl_o <= CTL_IDLE;
`endif
                end
                TX_HOLD: begin
                    hold_n <= hold_n + 7'd1;
`ifdef FW1394_DEFECT_NO_SECOND_GRANT
                    if (hold_n == 7'd0) fetched <= reg_rdata;
`endif
                    if (hold_n == HOLD_CYCLES - 1) begin
                        tx_state <= TX_PKT;
                        ctl_o <= CTL_DATA;
                        tx_q <= {resp_dest, resp_tl, 2'b00, resp_tcode, 4'h0};
                        tx_byte <= resp_dest[15:8];
                        tx_b <= 2'd0;
                        tx_qi <= 16'd0;
                        tx_crc <= 32'hFFFFFFFF;
                    end
                end
                TX_PKT: begin
                    // tx_byte is on the wire this cycle; tx_q holds it and the bytes after it.
                    if (!crc_quadlet) tx_crc <= crc_now;
                    if (tx_b != 2'd3) begin
                        tx_q <= {tx_q[23:0], 8'h00};
                        tx_byte <= tx_q[23:16];
                        tx_b <= tx_b + 2'd1;
                        // Data quadlet k (k >= 1) is read while quadlet 4 + k goes out.
                        if (tx_b == 2'd0 && tx_block && tx_qi >= 16'd5
                            && tx_qi - 16'd4 < resp_ndq) begin
                            reg_addr <= resp_index + (tx_qi - 16'd4);
                            reg_blk_rd <= 1'b1;
                        end
                        if (tx_b == 2'd1 && tx_qi >= 16'd5) fetched <= reg_rdata;
                    end else if (tx_qi == last_q) begin
                        tx_state <= TX_CLOSE;
                        respond <= 1'b0;
                        second <= 1'b0;
                        ctl_o <= CTL_IDLE;
                        tx_byte <= 8'h00;
                    end else begin
                        tx_q <= next_quadlet(tx_qi + 16'd1);
                        tx_byte <= next_quadlet(tx_qi + 16'd1) >> 24;
                        tx_b <= 2'd0;
                        tx_qi <= tx_qi + 16'd1;
                        // The data CRC starts after the header CRC.
                        if (tx_qi == 16'd3) tx_crc <= 32'hFFFFFFFF;
                    end
                end
                TX_END: begin
                    // Release; after a concatenation request, wait for the next Grant.
                    tx_state <= second ? TX_WAIT : TX_IDLE;
                    ctl_oe <= 1'b0;
                    d_oe <= 1'b0;
                end
                default: ;
            endcase
            end

            // ------------------------------------------------ write commit
            if (cm_active) begin
                reg_addr <= cm_index + cm_k;
                reg_len <= cm_len;
                reg_wdata <= cm_block ? wbuf[cm_k % MAXQ] : cm_qdata;
                if (cm_block) reg_blk_wr <= 1'b1;
                else reg_wr <= 1'b1;
                cm_k <= cm_k + 16'd1;
                if (cm_k + 16'd1 >= cm_n) cm_active <= 1'b0;
            end
        end
    end
endmodule
