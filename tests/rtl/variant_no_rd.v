`timescale 1ns/1ps
// The thesis link behind a plainer register bus: an 8-bit address, read data
// that must follow the address (no read strobe), one write enable for quadlets
// and blocks alike.
module variant_no_rd (
    input  wire        sclk,
    input  wire        rst,
    inout  wire [1:0]  ctl,
    inout  wire [7:0]  d,
    output wire        lreq,
    output wire        busy,
    output wire [7:0]  a,
    input  wire [31:0] q,
    output wire [31:0] dw,
    output wire        we
);
    wire [15:0] reg_addr, reg_len;
    wire        reg_rd, reg_blk_rd, reg_wr, reg_blk_wr;

    assign a = reg_addr[7:0];
    assign we = reg_wr | reg_blk_wr;
    fw1394_thesis_regbus link (
        .sclk(sclk), .rst(rst), .ctl(ctl), .d(d), .lreq(lreq), .busy(busy),
        .reg_addr(reg_addr), .reg_len(reg_len), .reg_rd(reg_rd), .reg_blk_rd(reg_blk_rd),
        .reg_wr(reg_wr), .reg_blk_wr(reg_blk_wr), .reg_wdata(dw), .reg_rdata(q)
    );
endmodule
