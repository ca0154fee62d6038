`timescale 1ns/1ps
// The thesis link as another design might wire it: separate in/out/enable pins,
// CTL0 in bit 0, D0 in bit 0, reset active low, its own names.
module variant_split_lsb (
    input  wire        clk49,
    input  wire        nreset,
    input  wire [1:0]  ctl_from_phy,
    output wire [1:0]  ctl_to_phy,
    output wire        ctl_drive,
    input  wire [7:0]  data_from_phy,
    output wire [7:0]  data_to_phy,
    output wire        data_drive,
    output wire        link_request,
    output wire        working
);
    wire [1:0]  ctl_o;
    wire [7:0]  d_o;
    wire [5:0]  phy_id;
    wire        phy_id_valid;
    wire [15:0] reg_addr, reg_len;
    wire        reg_rd, reg_blk_rd, reg_wr, reg_blk_wr;
    wire [31:0] reg_wdata, reg_rdata;

    fw1394_link link (
        .clk(clk49), .rst(!nreset),
        .ctl_i({ctl_from_phy[0], ctl_from_phy[1]}), .ctl_o(ctl_o), .ctl_oe(ctl_drive),
        .d_i({data_from_phy[0], data_from_phy[1], data_from_phy[2], data_from_phy[3],
              data_from_phy[4], data_from_phy[5], data_from_phy[6], data_from_phy[7]}),
        .d_o(d_o), .d_oe(data_drive), .lreq(link_request),
        .phy_id(phy_id), .phy_id_valid(phy_id_valid), .busy(working),
        .reg_addr(reg_addr), .reg_len(reg_len), .reg_rd(reg_rd), .reg_blk_rd(reg_blk_rd),
        .reg_wr(reg_wr), .reg_blk_wr(reg_blk_wr), .reg_wdata(reg_wdata), .reg_rdata(reg_rdata)
    );
    assign ctl_to_phy = {ctl_o[0], ctl_o[1]};
    assign data_to_phy = {d_o[0], d_o[1], d_o[2], d_o[3], d_o[4], d_o[5], d_o[6], d_o[7]};
    fw1394_regs #(.BOARD_ID(4'd5)) regs (
        .clk(clk49), .rst(!nreset),
        .reg_addr(reg_addr), .reg_len(reg_len), .reg_wr(reg_wr), .reg_blk_wr(reg_blk_wr),
        .reg_wdata(reg_wdata), .reg_rdata(reg_rdata)
    );
endmodule
