`timescale 1ns/1ps
// The thesis link with its register bus on pins, for a harness (or the rest of
// an FPGA) to serve; CTL and D as bidirectional pins.
module fw1394_thesis_regbus (
    input  wire        sclk,
    input  wire        rst,
    inout  wire [1:0]  ctl,
    inout  wire [7:0]  d,
    output wire        lreq,
    output wire        busy,
    output wire [15:0] reg_addr,
    output wire [15:0] reg_len,
    output wire        reg_rd,
    output wire        reg_blk_rd,
    output wire        reg_wr,
    output wire        reg_blk_wr,
    output wire [31:0] reg_wdata,
    input  wire [31:0] reg_rdata
);
    wire [1:0] ctl_o;
    wire [7:0] d_o;
    wire       ctl_oe, d_oe, phy_id_valid;
    wire [5:0] phy_id;

    assign ctl = ctl_oe ? ctl_o : 2'bzz;
    assign d = d_oe ? d_o : 8'hzz;

    fw1394_link link (
        .clk(sclk), .rst(rst),
        .ctl_i(ctl), .ctl_o(ctl_o), .ctl_oe(ctl_oe),
        .d_i(d), .d_o(d_o), .d_oe(d_oe), .lreq(lreq),
        .phy_id(phy_id), .phy_id_valid(phy_id_valid), .busy(busy),
        .reg_addr(reg_addr), .reg_len(reg_len), .reg_rd(reg_rd), .reg_blk_rd(reg_blk_rd),
        .reg_wr(reg_wr), .reg_blk_wr(reg_blk_wr), .reg_wdata(reg_wdata), .reg_rdata(reg_rdata)
    );
endmodule
