`timescale 1ns/1ps
// The thesis link behind split pins with a PHY-drives flag that the wrapper
// follows with an always block on the flag, as board wrappers do: a harness
// that sets the flag at time 0 without an event leaves it unknown.
// (Otherwise as variant_flag.v:) the board tells the
// link when the PHY drives (phy_owns); CTL0 and D0 in the high bits, reset active high.
module variant_flag_event (
    input  wire       sclk,
    input  wire       reset,
    input  wire       phy_owns,
    input  wire [1:0] ctl_in,
    output wire [1:0] ctl_out,
    input  wire [7:0] d_in,
    output wire [7:0] d_out,
    output wire       lreq,
    output wire       busy
);
    wire [1:0]  ctl_o;
    wire [7:0]  d_o;
    wire        ctl_oe, d_oe, phy_id_valid;
    wire [5:0]  phy_id;
    wire [15:0] reg_addr, reg_len;
    wire        reg_rd, reg_blk_rd, reg_wr, reg_blk_wr;
    wire [31:0] reg_wdata, reg_rdata;

    reg owns;
    always @(phy_owns) owns = phy_owns;

    // Idle on the outputs whenever the link is not driving.
    assign ctl_out = ctl_oe ? ctl_o : 2'b00;
    assign d_out = d_oe ? d_o : 8'h00;
    fw1394_link link (
        .clk(sclk), .rst(reset),
        .ctl_i(owns ? ctl_in : 2'b00), .ctl_o(ctl_o), .ctl_oe(ctl_oe),
        .d_i(owns ? d_in : 8'h00), .d_o(d_o), .d_oe(d_oe), .lreq(lreq),
        .phy_id(phy_id), .phy_id_valid(phy_id_valid), .busy(busy),
        .reg_addr(reg_addr), .reg_len(reg_len), .reg_rd(reg_rd), .reg_blk_rd(reg_blk_rd),
        .reg_wr(reg_wr), .reg_blk_wr(reg_blk_wr), .reg_wdata(reg_wdata), .reg_rdata(reg_rdata)
    );
    fw1394_regs #(.BOARD_ID(4'd5)) regs (
        .clk(sclk), .rst(reset),
        .reg_addr(reg_addr), .reg_len(reg_len), .reg_wr(reg_wr), .reg_blk_wr(reg_blk_wr),
        .reg_wdata(reg_wdata), .reg_rdata(reg_rdata)
    );
endmodule
