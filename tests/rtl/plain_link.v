`timescale 1ns/1ps
// A small 1394 link written for the tests from the PHY-link interface facts
// alone (phy-link.md: Pins, CTL tables, Transmit, Receive, Status transfer,
// LREQ): not derived from fw1394's thesis link, so the PHY model is checked
// against a second reading of the same rules.
//
// Split pins with output enables. CTL0 is bit 0 of the CTL vectors (so
// Receive/Transmit is 2'b01 here) and D0 is bit 7. Reset is active low.
//
// What it does, as the thesis contract asks of a node:
//   * takes every packet the PHY delivers at S400 (others are ignored);
//   * keeps quadlet and block reads and writes addressed to its physical ID
//     (63: broadcast writes, performed and never acked) whose header CRC, data
//     CRC (over the data with its padding taken as zeros) and length are right,
//     and drops everything else without an ack;
//   * acks a write ack_complete (blocks over 2048 bytes: ack_data_error,
//     nothing written) and a read ack_pending, which it ends with Hold (a
//     concatenation request), one more Idle, and a release; when the PHY grants
//     the bus again it sends the read response (over 2048 bytes: resp_data_error);
//   * learns its physical ID from every 16-bit status transfer of PHY register 0.
// Its registers are outside: one strobe per quadlet, read data one cycle later.
module plain_link (
    input  wire        clock,
    input  wire        rst_n,
    input  wire [1:0]  ctl_in,
    output reg  [1:0]  ctl_out,
    output reg         ctl_en,
    input  wire [7:0]  d_in,
    output reg  [7:0]  d_out,
    output reg         d_en,
    output reg         link_req,
    output wire        working,
    output reg  [15:0] bus_addr,
    output reg  [15:0] bus_len,
    output reg         bus_rd,
    output reg         bus_brd,
    output reg         bus_wr,
    output reg         bus_bwr,
    output reg  [31:0] bus_wdata,
    input  wire [31:0] bus_rdata
);
    // CTL as {CTL1, CTL0}.
    localparam [1:0] C_IDLE = 2'b00, C_STATUS = 2'b10, C_RECEIVE = 2'b01, C_GRANT = 2'b11;
    localparam [1:0] C_HOLD = 2'b10, C_TRANSMIT = 2'b01;
    localparam [7:0] SPEED_S400 = 8'h50;
    localparam [15:0] LIMIT = 16'd2048;
    localparam DEPTH = 6 + 512;

    // The CRC-32 of IEEE 1394 (polynomial 04C11DB7, MSB first, start all ones,
    // sent inverted), one byte at a time.
    function [31:0] crc_byte;
        input [31:0] c;
        input [7:0] b;
        integer i;
        begin
            crc_byte = c;
            for (i = 7; i >= 0; i = i - 1)
                crc_byte = {crc_byte[30:0], 1'b0} ^ ((crc_byte[31] ^ b[i]) ? 32'h04C11DB7 : 32'h0);
        end
    endfunction

    function [31:0] crc_quad;
        input [31:0] c;
        input [31:0] q;
        begin
            crc_quad = crc_byte(crc_byte(crc_byte(crc_byte(c, q[31:24]), q[23:16]), q[15:8]),
                                q[7:0]);
        end
    endfunction

    // ------------------------------------------------------------------ receive
    localparam [2:0] R_IDLE = 3'd0, R_ON = 3'd1, R_DATA = 3'd2, R_STATUS = 3'd3, R_DONE = 3'd4;
    reg [2:0]  r_state;
    reg [19:0] nbytes;
    reg [23:0] partial;
    reg [31:0] crc_run, crc3, crc4, dcrc;
    reg [31:0] rxq [0:DEPTH-1];
    reg [15:0] st_sh;
    reg [3:0]  st_cnt;
    reg [5:0]  phy_id;
    reg        id_ok;

    wire [31:0] word = {partial, d_in};
    wire [17:0] qn = nbytes[19:2];
    wire [3:0]  tcode = rxq[0][7:4];
    wire [15:0] rx_len = rxq[3][31:16];
    wire [16:0] rx_ndq = ({1'b0, rx_len} + 17'd3) >> 2;
    // The data region of a block write: bytes 20 .. 20 + 4 * ndq - 1.
    wire [19:0] data_pos = nbytes - 20'd20;
    wire        in_data = tcode == 4'h1 && qn >= 18'd5 && data_pos < {1'b0, rx_ndq, 2'b00};

    // The decision, valid in R_DONE.
    wire        quad_read = tcode == 4'h4;
    wire        supported = tcode == 4'h0 || tcode == 4'h1 || tcode == 4'h4 || tcode == 4'h5;
    wire [19:0] want_bytes = tcode == 4'h4 ? 20'd16
                           : tcode == 4'h1 ? 20'd24 + {1'b0, rx_ndq, 2'b00} : 20'd20;
    wire        header_ok = quad_read ? rxq[3] == ~crc3 : rxq[4] == ~crc4;
    reg  [31:0] last_word;      // the last quadlet received: a block's data CRC
    wire        data_ok = tcode != 4'h1 || last_word == ~dcrc;
    wire [5:0]  to = rxq[0][21:16];
    wire        to_all = to == 6'd63;
    wire        for_me = id_ok && (to == phy_id || to_all);
    wire        keep = for_me && supported && nbytes == want_bytes && header_ok && data_ok;
    wire        writing = tcode == 4'h0 || tcode == 4'h1;
    wire        big = (tcode == 4'h1 || tcode == 4'h5) && rx_len > LIMIT;

    // ------------------------------------------------------------------ transmit
    localparam [3:0] T_IDLE = 4'd0, T_REQ = 4'd1, T_WAIT = 4'd2, T_GRANTED = 4'd3,
                     T_TAKE = 4'd4, T_ACK = 4'd5, T_END = 4'd6, T_CLOSE = 4'd7,
                     T_SEND = 4'd8;
    reg [3:0]  t_state;
    reg [7:0]  req_bits;
    reg [3:0]  req_left;
    reg        answer_read;     // a response follows the ack
    reg        response_turn;   // the next grant is for the response
    reg [3:0]  ack;
    reg [15:0] to_node, index, length;
    reg [5:0]  label;
    reg        block, error;
    reg [16:0] ndq;             // data quadlets of the response
    reg [31:0] first_data, next_data, current, hdr_crc, data_crc;
    reg [1:0]  byte_no;
    reg [16:0] quad_no;

    wire [31:0] h0 = {to_node, label, 2'b00, block ? 4'h7 : 4'h6, 4'h0};
    wire [31:0] h1 = {10'h3FF, phy_id, error ? 4'h5 : 4'h0, 12'h0};
    wire [31:0] h3 = block ? {error ? 16'h0 : length, 16'h0} : first_data;
    wire [16:0] last_quad = block ? 17'd5 + ndq : 17'd4;

    // Data quadlet k of the response, the bytes past the length as zeros.
    function [31:0] clipped;
        input [31:0] value;
        input [16:0] k;
        input [15:0] len;
        reg [18:0] start;
        begin
            start = {k, 2'b00};
            clipped = value;
            if (start + 19'd4 > {3'b000, len}) begin
                if (start >= {3'b000, len}) clipped = 32'h0;
                else case (len[1:0])
                    2'd1: clipped = {value[31:24], 24'h0};
                    2'd2: clipped = {value[31:16], 16'h0};
                    2'd3: clipped = {value[31:8], 8'h0};
                    default: ;
                endcase
            end
        end
    endfunction

    // ------------------------------------------------------------------ write commit
    reg        w_active, w_block;
    reg [16:0] w_k, w_n;
    reg [15:0] w_index, w_len;

    assign working = r_state == R_DONE || t_state != T_IDLE || w_active;

    always @(posedge clock) begin
        if (!rst_n) begin
            r_state <= R_IDLE;
            t_state <= T_IDLE;
            id_ok <= 1'b0;
            phy_id <= 6'd0;
            st_cnt <= 4'd0;
            link_req <= 1'b0;
            ctl_out <= C_IDLE;
            ctl_en <= 1'b0;
            d_out <= 8'h00;
            d_en <= 1'b0;
            bus_rd <= 1'b0;
            bus_brd <= 1'b0;
            bus_wr <= 1'b0;
            bus_bwr <= 1'b0;
            bus_addr <= 16'h0;
            bus_len <= 16'h0;
            bus_wdata <= 32'h0;
            w_active <= 1'b0;
            response_turn <= 1'b0;
        end else begin
            bus_rd <= 1'b0;
            bus_brd <= 1'b0;
            bus_wr <= 1'b0;
            bus_bwr <= 1'b0;

            case (r_state)
                R_IDLE:
                    if (ctl_in == C_RECEIVE && d_in == 8'hFF) r_state <= R_ON;
                    else if (ctl_in == C_STATUS) begin
                        st_sh <= {14'h0, d_in[7], d_in[6]};
                        st_cnt <= 4'd1;
                        r_state <= R_STATUS;
                    end
                R_STATUS:
                    if (ctl_in == C_STATUS) begin
                        st_sh <= {st_sh[13:0], d_in[7], d_in[6]};
                        st_cnt <= st_cnt + 4'd1;
                    end else begin
                        // S0..S15 complete, S4-S7 register 0: S8-S13 is the physical ID.
                        if (st_cnt == 4'd8 && st_sh[11:8] == 4'd0) begin
                            phy_id <= st_sh[7:2];
                            id_ok <= 1'b1;
                        end
                        r_state <= ctl_in == C_RECEIVE && d_in == 8'hFF ? R_ON : R_IDLE;
                    end
                R_ON:
                    if (ctl_in != C_RECEIVE) r_state <= R_IDLE;        // a null packet
                    else if (d_in != 8'hFF) begin
                        r_state <= d_in == SPEED_S400 ? R_DATA : R_IDLE;
                        nbytes <= 20'd0;
                        crc_run <= 32'hFFFFFFFF;
                        dcrc <= 32'hFFFFFFFF;
                        rxq[0] <= 32'hFFFFFFFF;                      // no tcode yet
                        rxq[3] <= 32'h0;
                    end
                R_DATA:
                    if (ctl_in != C_RECEIVE) r_state <= R_DONE;
                    else begin
                        if (nbytes != 20'hFFFFF) nbytes <= nbytes + 20'd1;
                        partial <= word[23:0];
                        crc_run <= crc_byte(crc_run, d_in);
                        if (in_data)
                            dcrc <= crc_byte(dcrc, data_pos < {4'h0, rx_len} ? d_in : 8'h00);
                        if (nbytes[1:0] == 2'd3) begin
                            if (qn < DEPTH) rxq[qn] <= word;
                            last_word <= word;
                            if (qn == 18'd2) crc3 <= crc_byte(crc_run, d_in);
                            if (qn == 18'd3) crc4 <= crc_byte(crc_run, d_in);
                        end
                    end
                R_DONE: begin
                    r_state <= R_IDLE;
                    if (keep && t_state == T_IDLE && !w_active) begin
                        if (writing && !big) begin
                            w_active <= 1'b1;
                            w_block <= tcode == 4'h1;
                            w_k <= 17'd0;
                            w_n <= tcode == 4'h1 && rx_ndq != 17'd0 ? rx_ndq : 17'd1;
                            w_index <= rxq[2][15:0];
                            w_len <= rx_len;
                        end
                        if (!to_all) begin
                            // ImmReq at S400: start bit, type 000, speed 100, stop bit.
                            req_bits <= 8'b1000_1000;
                            req_left <= 4'd8;
                            t_state <= T_REQ;
                            answer_read <= !writing;
                            ack <= !writing ? 4'h2 : big ? 4'hD : 4'h1;
                            to_node <= rxq[1][31:16];
                            label <= rxq[0][15:10];
                            index <= rxq[2][15:0];
                            block <= tcode == 4'h5;
                            error <= big;
                            length <= tcode == 4'h5 && !big ? rx_len : 16'h0;
                            ndq <= tcode == 4'h5 && !big ? rx_ndq : 17'd0;
                        end
                    end
                end
                default: r_state <= R_IDLE;
            endcase

            case (t_state)
                T_REQ: begin
                    link_req <= req_bits[7];
                    req_bits <= {req_bits[6:0], 1'b0};
                    req_left <= req_left - 4'd1;
                    if (req_left == 4'd1) t_state <= T_WAIT;
                end
                T_WAIT: begin
                    link_req <= 1'b0;
                    if (ctl_in == C_GRANT) t_state <= T_GRANTED;
                end
                // The PHY drives Idle for one cycle after Grant, then lets go.
                T_GRANTED: t_state <= T_TAKE;
                T_TAKE: begin
                    ctl_en <= 1'b1;
                    d_en <= 1'b1;
                    ctl_out <= C_TRANSMIT;
                    if (response_turn) begin
                        response_turn <= 1'b0;
                        answer_read <= 1'b0;
                        hdr_crc <= ~crc_quad(crc_quad(crc_quad(crc_quad(32'hFFFFFFFF, h0), h1),
                                                      32'h0), h3);
                        data_crc <= 32'hFFFFFFFF;
                        current <= h0;
                        d_out <= h0[31:24];
                        byte_no <= 2'd0;
                        quad_no <= 17'd0;
                        next_data <= first_data;
                        t_state <= T_SEND;
                    end else begin
                        d_out <= {ack, ~ack};
                        t_state <= T_ACK;
                    end
                end
                T_ACK: begin
                    // Hold ends the ack of a read (concatenation), Idle that of a write.
                    ctl_out <= answer_read ? C_HOLD : C_IDLE;
                    d_out <= 8'h00;
                    t_state <= T_END;
                    if (answer_read && !error) begin
                        bus_addr <= index;
                        bus_len <= length;
                        if (block) bus_brd <= 1'b1;
                        else bus_rd <= 1'b1;
                    end
                end
                T_END: begin
                    ctl_out <= C_IDLE;
                    t_state <= T_CLOSE;
                    if (answer_read) begin
                        first_data <= error ? 32'h0 : bus_rdata;
                        response_turn <= 1'b1;
                    end
                end
                T_CLOSE: begin
                    ctl_en <= 1'b0;
                    d_en <= 1'b0;
                    t_state <= response_turn ? T_WAIT : T_IDLE;
                end
                T_SEND: begin
                    if (byte_no == 2'd0 && block && quad_no >= 17'd5 && quad_no - 17'd4 < ndq) begin
                        // Data quadlet quad_no - 4 is fetched while quadlet quad_no goes out.
                        bus_addr <= index + quad_no[15:0] - 16'd4;
                        bus_len <= length;
                        bus_brd <= 1'b1;
                    end
                    if (byte_no == 2'd1 && block && quad_no >= 17'd5) next_data <= bus_rdata;
                    if (byte_no != 2'd3) begin
                        byte_no <= byte_no + 2'd1;
                        d_out <= byte_no == 2'd0 ? current[23:16]
                               : byte_no == 2'd1 ? current[15:8] : current[7:0];
                    end else if (quad_no == last_quad) begin
                        ctl_out <= C_IDLE;
                        d_out <= 8'h00;
                        t_state <= T_END;
                    end else begin
                        byte_no <= 2'd0;
                        quad_no <= quad_no + 17'd1;
                        case (quad_no + 17'd1)
                            17'd1: current <= h1;
                            17'd2: current <= 32'h0;
                            17'd3: current <= h3;
                            17'd4: current <= hdr_crc;
                            default:
                                if (quad_no + 17'd1 == last_quad) current <= ~data_crc;
                                else begin
                                    current <= clipped(next_data, quad_no - 17'd4, length);
                                    data_crc <= crc_quad(data_crc,
                                                         clipped(next_data, quad_no - 17'd4, length));
                                end
                        endcase
                        d_out <= quad_no + 17'd1 == 17'd1 ? h1[31:24]
                               : quad_no + 17'd1 == 17'd2 ? 8'h00
                               : quad_no + 17'd1 == 17'd3 ? h3[31:24]
                               : quad_no + 17'd1 == 17'd4 ? hdr_crc[31:24]
                               : quad_no + 17'd1 == last_quad ? ~data_crc[31:24]
                               : clipped(next_data, quad_no - 17'd4, length) >> 24;
                    end
                end
                default: ;
            endcase

            if (w_active) begin
                bus_addr <= w_index + w_k[15:0];
                bus_len <= w_len;
                bus_wdata <= w_block ? rxq[17'd5 + w_k] : rxq[3];
                if (w_block) bus_bwr <= 1'b1;
                else bus_wr <= 1'b1;
                w_k <= w_k + 17'd1;
                if (w_k + 17'd1 >= w_n) w_active <= 1'b0;
            end
        end
    end
endmodule
