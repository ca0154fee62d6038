`timescale 1ns/1ps
// Registers of a node with its own register file: the status register of the
// thesis's Table 2 (board ID, amplifier enables written through their mask),
// a version register, and 256 quadlets of scratch memory behind the rest of
// the 8-bit register index. Reads are combinational: the link samples
// reg_rdata at the end of the strobe's cycle.
module fw1394_regs #(
    parameter [3:0]  BOARD_ID = 4'd0,
    parameter [31:0] VERSION = 32'h0000_0001
) (
    input  wire        clk,
    input  wire        rst,
    input  wire [15:0] reg_addr,
    input  wire [15:0] reg_len,
    input  wire        reg_wr,
    input  wire        reg_blk_wr,
    input  wire [31:0] reg_wdata,
    output wire [31:0] reg_rdata
);
    localparam [15:0] STATUS = 16'd0, VERSION_REG = 16'd4;
    reg [31:0] ram [0:255];
    reg [7:0]  enables;
    reg [15:0] block_k;   // quadlet of the block write under way
    integer i;

    wire [31:0] status = {4'h0, BOARD_ID, 16'h0, enables};
    assign reg_rdata = reg_addr == STATUS ? status
                     : reg_addr == VERSION_REG ? VERSION
                     : reg_addr <= 16'd255 ? ram[reg_addr[7:0]] : 32'h0;

    // A block write's trailing partial quadlet is dropped, as the thesis board does.
    wire [17:0] block_end = {block_k, 2'b00} + 18'd4;
    wire        write = reg_wr || (reg_blk_wr && block_end <= {2'b00, reg_len});

    always @(posedge clk) begin
        if (rst) begin
            enables <= 8'h00;
            block_k <= 16'd0;
            for (i = 0; i < 256; i = i + 1) ram[i] <= 32'h0;
        end else begin
            block_k <= reg_blk_wr ? block_k + 16'd1 : 16'd0;
            if (write) begin
                if (reg_addr == STATUS)
                    enables <= (enables & ~reg_wdata[15:8]) | (reg_wdata[7:0] & reg_wdata[15:8]);
                else if (reg_addr != VERSION_REG && reg_addr <= 16'd255)
                    ram[reg_addr[7:0]] <= reg_wdata;
            end
        end
    end
endmodule
