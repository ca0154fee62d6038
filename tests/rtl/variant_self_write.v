`timescale 1ns/1ps
// The thesis link with its register bus on pins, beside logic that writes
// register 3 by itself every 64 cycles (a status word the design keeps up to
// date, as a link copying PHY status into a register does), whenever the link
// leaves the bus free.
module variant_self_write (
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
    wire [1:0]  ctl_o;
    wire [7:0]  d_o;
    wire        ctl_oe, d_oe, phy_id_valid;
    wire [5:0]  phy_id;
    wire [15:0] link_addr;
    wire        link_wr;
    wire [31:0] link_wdata;
    reg  [15:0] ticks;
    reg         own_wr;

    assign ctl = ctl_oe ? ctl_o : 2'bzz;
    assign d = d_oe ? d_o : 8'hzz;
    always @(posedge sclk) begin
        ticks <= rst ? 16'h0 : ticks + 16'h1;
        own_wr <= !rst && ticks[5:0] == 6'h3F && !busy;
    end
    assign reg_wr = link_wr | own_wr;
    assign reg_addr = own_wr ? 16'h3 : link_addr;
    assign reg_wdata = own_wr ? {16'h5AA5, ticks} : link_wdata;

    fw1394_link link (
        .clk(sclk), .rst(rst),
        .ctl_i(ctl), .ctl_o(ctl_o), .ctl_oe(ctl_oe),
        .d_i(d), .d_o(d_o), .d_oe(d_oe), .lreq(lreq),
        .phy_id(phy_id), .phy_id_valid(phy_id_valid), .busy(busy),
        .reg_addr(link_addr), .reg_len(reg_len), .reg_rd(reg_rd), .reg_blk_rd(reg_blk_rd),
        .reg_wr(link_wr), .reg_blk_wr(reg_blk_wr), .reg_wdata(link_wdata),
        .reg_rdata(reg_rdata)
    );
endmodule
