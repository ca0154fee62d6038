`timescale 1ns/1ps
// The thesis link with its LREQ line delayed by DELAY cycles: its acks come late.
module variant_slow_lreq #(
    parameter DELAY = 16
) (
    input  wire       sclk,
    input  wire       rst,
    inout  wire [1:0] ctl,
    inout  wire [7:0] d,
    output wire       lreq,
    output wire       busy
);
    wire             link_lreq;
    reg  [DELAY-1:0] line = {DELAY{1'b0}};

    always @(posedge sclk) line <= {line[DELAY-2:0], link_lreq};
    assign lreq = line[DELAY-1];
    fw1394_thesis_node node (
        .sclk(sclk), .rst(rst), .ctl(ctl), .d(d), .lreq(link_lreq), .busy(busy)
    );
endmodule
