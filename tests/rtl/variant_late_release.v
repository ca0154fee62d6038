`timescale 1ns/1ps
// A broken wrapper of the thesis link: its output enables let go three cycles
// late, so the link still drives after its closing Idle, in the turnaround
// cycle, and when the PHY has taken the interface back.
module variant_late_release (
    input  wire       sclk,
    input  wire       rst,
    input  wire [1:0] ctl_i,
    output wire [1:0] ctl_o,
    output wire       ctl_oe,
    input  wire [7:0] d_i,
    output wire [7:0] d_o,
    output wire       d_oe,
    output wire       lreq,
    output wire       busy
);
    wire        link_ctl_oe, link_d_oe, phy_id_valid;
    wire [5:0]  phy_id;
    wire [15:0] reg_addr, reg_len;
    wire        reg_rd, reg_blk_rd, reg_wr, reg_blk_wr;
    wire [31:0] reg_wdata, reg_rdata;
    reg         late = 1'b0, later = 1'b0, latest = 1'b0;

    always @(posedge sclk) begin
        late <= link_ctl_oe;
        later <= late;
        latest <= later;
    end
    assign ctl_oe = link_ctl_oe | late | later | latest;
    assign d_oe = link_d_oe | late | later | latest;
    fw1394_link link (
        .clk(sclk), .rst(rst),
        .ctl_i(ctl_i), .ctl_o(ctl_o), .ctl_oe(link_ctl_oe),
        .d_i(d_i), .d_o(d_o), .d_oe(link_d_oe), .lreq(lreq),
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
