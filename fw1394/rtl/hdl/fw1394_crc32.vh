// One byte of the IEEE 1394 CRC-32 (polynomial 0x04C11DB7, MSB first).
// The register starts at all ones; the CRC quadlet on the wire is its complement.
function [31:0] crc32_byte;
    input [31:0] crc;
    input [7:0] data;
    integer i;
    reg [31:0] c;
    begin
        c = crc;
        for (i = 7; i >= 0; i = i - 1)
            c = {c[30:0], 1'b0} ^ ((c[31] ^ data[i]) ? 32'h04C11DB7 : 32'h0);
        crc32_byte = c;
    end
endfunction
