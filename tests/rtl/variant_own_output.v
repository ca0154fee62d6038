`timescale 1ns/1ps
// A broken wrapper of the thesis link: its CTL and D inputs are wired to the
// link's own output registers instead of the pins, so it never hears the PHY.
module variant_own_output (
    input  wire       sclk,
    input  wire       rst,
    inout  wire [1:0] ctl,
    inout  wire [7:0] d,
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

    assign ctl = ctl_oe ? ctl_o : 2'bzz;
    assign d = d_oe ? d_o : 8'hzz;
    fw1394_link link (
        .clk(sclk), .rst(rst),
        .ctl_i(ctl_o), .ctl_o(ctl_o), .ctl_oe(ctl_oe),
        .d_i(d_o), .d_o(d_o), .d_oe(d_oe), .lreq(lreq),
        .phy_id(phy_id), .phy_id_valid(phy_id_valid), .busy(busy),
        .reg_addr(reg_addr), .reg_len(reg_len), .reg_rd(reg_rd), .reg_blk_rd(reg_blk_rd),
        .reg_wr(reg_wr), .reg_blk_wr(reg_blk_wr), .reg_wdata(reg_wdata), .reg_rdata(reg_rdata)
    );
    fw1394_regs regs (
        .clk(sclk), .rst(rst),
        .reg_addr(reg_addr), .reg_len(reg_len), .reg_wr(reg_wr), .reg_blk_wr(reg_blk_wr),
        .reg_wdata(reg_wdata), .reg_rdata(reg_rdata)
    );
endmodule
