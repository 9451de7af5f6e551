// fp_lzc: leading-zero count of a WIDTH-bit vector (combinational priority encoder).
//
// count = number of zeros above the most significant one; count = WIDTH when x == 0.
// Exceptions: none. Latency: 0 (combinational).
`default_nettype none

module fp_lzc #(
    parameter  int WIDTH = 32,
    localparam int CW    = $clog2(WIDTH + 1)
) (
    input  wire logic [WIDTH-1:0] x,
    output logic [CW-1:0]         count
);
    always_comb begin
        count = CW'(WIDTH);
        for (int i = 0; i < WIDTH; i++) begin
            if (x[i]) count = CW'(WIDTH - 1 - i);
        end
    end
endmodule

`default_nettype wire
