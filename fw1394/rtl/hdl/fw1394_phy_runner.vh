// The PHY model's runner, included in the harness module fw1394_harness.
//
// Stepping every SCLK cycle from Python costs tens of microseconds a cycle; most
// cycles of an exchange need nothing from the PHY model but a value on the pins
// (a packet's symbols, Idle while the link thinks). The runner drives those
// cycles here and stops at the first cycle the model must look at: the link
// drives the pins (unless it transmits data being captured), a register strobe,
// a side effect, a complete or malformed link request, the end of the words, or
// the condition it was asked to wait for. The cycle it stops at is handed back
// exactly as a stepped cycle would be, with what happened in the cycles before.
//
// run_cmd (written last, any change starts a run; fields from bit 0):
//   [0] play run_words (else hold one word)  [1] capture Transmit cycles
//   [3:2] until: 0 nothing, 1 LREQ quiet, 2 link not busy  [4] stop at register strobes
//   [15:5] the word to hold  [39:16] words to play, or most cycles to hold
//   [63:40] quiet cycles so far  [79:64] quiet cycles wanted
//   [80] an LREQ request being received  [85:81] its bits so far  [101:86] those bits
//   [106:102] its length (0: type not known yet)  [114:107] sequence number
// run_report (valid when run_done toggles):
//   [18:0] mon of the last cycle (X and Z as 0)  [19] mon had X or Z bits
//   [43:20] cycles run  [67:44] quiet cycles  [83:68] LREQ bits of the cycles before
//   the last (oldest highest)  [88:84] how many  [95:89] bytes in run_capture
    localparam RUN_SLOTS = 64;
    reg [16*RUN_SLOTS-1:0] run_words;
    reg [127:0] run_cmd;
    reg [127:0] run_report = 128'h0;
    reg [8*RUN_SLOTS-1:0] run_capture = 0;
    reg run_done = 1'b0;
    reg run_on = 1'b0;
    reg run_play, run_cap, run_strobes;
    reg [1:0] run_until;
    reg [10:0] run_hold;
    reg [23:0] run_count, run_n, run_quiet;
    reg [15:0] run_qlimit, run_lq;
    reg run_dbusy;
    reg [4:0] run_dn, run_need, run_lqn;
    reg [15:0] run_dbits;
    reg [6:0] run_capn;

    always @(run_cmd) begin
        run_play = run_cmd[0];
        run_cap = run_cmd[1];
        run_until = run_cmd[3:2];
        run_strobes = run_cmd[4];
        run_hold = run_cmd[15:5];
        run_count = run_cmd[39:16];
        run_quiet = run_cmd[63:40];
        run_qlimit = run_cmd[79:64];
        run_dbusy = run_cmd[80];
        run_dn = run_cmd[85:81];
        run_dbits = run_cmd[101:86];
        run_need = run_cmd[106:102];
        run_n = 0;
        run_lq = 0;
        run_lqn = 0;
        run_capn = 0;
        run_on = 1'b1;
        phy = run_play ? run_words[10:0] : run_hold;
    end

    always @(negedge sclk) begin : run_cycle
        reg [18:0] m;
        reg xz, l, was_busy, complete, reserved, free;
        integer i;
        if (run_on) begin
            xz = (^mon) === 1'bx;
            m = mon;
            if (xz) for (i = 0; i < 19; i = i + 1) m[i] = mon[i] === 1'b1;
            run_n = run_n + 1;
            l = m[11];
            was_busy = run_dbusy;
            complete = 1'b0;
            reserved = 1'b0;
            // The LREQ decoder, as the model's: a start bit, the type, its bits.
            if (!run_dbusy) begin
                if (l) begin
                    run_dbusy = 1'b1;
                    run_dn = 0;
                    run_dbits = 0;
                    run_need = 0;
                end
            end else begin
                run_dbits = {run_dbits[14:0], l};
                run_dn = run_dn + 1;
                if (run_dn == 3) begin
                    case (run_dbits[2:0])
                        3'd4: run_need = 8;
                        3'd5: run_need = 16;
                        3'd6: run_need = 5;
                        3'd7: run_need = 0;
                        default: run_need = 7;
                    endcase
                    if (run_dbits[2:0] == 3'd7) begin
                        reserved = 1'b1;
                        run_dbusy = 1'b0;
                    end
                end
                if (run_dbusy && run_need != 0 && run_dn == run_need) begin
                    complete = 1'b1;
                    run_dbusy = 1'b0;
                end
            end
            run_quiet = l ? 0 : run_quiet + 1;
            free = !complete && !reserved && !(|m[18:17]) && !(run_strobes && |m[16:13])
                && (!m[10] || (run_cap && m[9:8] == 2'b10 && !xz))
                && run_n < run_count
                && !(run_cap && run_capn == RUN_SLOTS)
                && !(run_until == 2'd1 && run_quiet >= run_qlimit && !run_dbusy)
                && !(run_until == 2'd2 && !m[12] && !run_dbusy);
            if (free) begin
                if (was_busy || l) begin
                    run_lq = {run_lq[14:0], l};
                    run_lqn = run_lqn + 1;
                end
                if (m[10]) begin
                    run_capture[8*run_capn +: 8] = m[7:0];
                    run_capn = run_capn + 1;
                end
                if (run_play) phy <= run_words[16*run_n +: 11];
            end else begin
                run_on = 1'b0;
                run_report = {32'h0, run_capn, run_lqn, run_lq, run_quiet, run_n, xz, m};
                run_done <= !run_done;
            end
        end
    end
