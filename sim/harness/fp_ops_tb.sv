// fp_ops_tb: test harness top with every fp operator for one format (EXP_BITS, MAN_BITS).
//
// One operand pair (a, b) per cycle goes to all operators at once: a + b, a - b (the `sub` input
// of a second fp_add), a * b, a / b, sqrt(a), and minimum / maximum / compare flags of (a, b).
// The lat_* outputs are the operators' LATENCY parameters, so the C++ driver can check that each
// result comes out exactly LATENCY cycles after its operands; *_flags are the operators' event flags
// ({invalid, underflow, overflow}). ADD_DSP: the two adders in fp_add's DSP48E2 form (SHIFT_DSP).
// Driven by fp_ops_main.cpp.
`default_nettype none

module fp_ops_tb #(
    parameter  int EXP_BITS       = 8,
    parameter  int MAN_BITS       = 23,
    parameter  int MINMAX_LATENCY = 2,
    parameter  bit ADD_DSP        = 1'b0,
    localparam int W              = 1 + EXP_BITS + MAN_BITS
) (
    input  wire logic         clk,
    input  wire logic         rst,
    input  wire logic         in_valid,
    input  wire logic [W-1:0] a,
    input  wire logic [W-1:0] b,

    output logic              add_valid,
    output logic [W-1:0]      add_y,
    output logic [2:0]        add_flags,
    output logic              sub_valid,
    output logic [W-1:0]      sub_y,
    output logic [2:0]        sub_flags,
    output logic              mul_valid,
    output logic [W-1:0]      mul_y,
    output logic [2:0]        mul_flags,
    output logic              div_valid,
    output logic [W-1:0]      div_y,
    output logic [2:0]        div_flags,
    output logic              sqrt_valid,
    output logic [W-1:0]      sqrt_y,
    output logic [2:0]        sqrt_flags,
    output logic              mm_valid,
    output logic [W-1:0]      min_y,
    output logic [W-1:0]      max_y,
    output logic [2:0]        cmp_flags,   // {unordered, eq, lt}

    output logic [7:0]        fmt_width,   // W, so the driver can mask its random idle data
    output logic [7:0]        lat_add,
    output logic [7:0]        lat_mul,
    output logic [7:0]        lat_div,
    output logic [7:0]        lat_sqrt,
    output logic [7:0]        lat_minmax
);
    fp_add #(.EXP_BITS(EXP_BITS), .MAN_BITS(MAN_BITS), .SHIFT_DSP(ADD_DSP)) u_add (
        .clk, .rst, .in_valid, .a, .b, .sub(1'b0), .out_valid(add_valid), .y(add_y), .flags(add_flags)
    );
    fp_add #(.EXP_BITS(EXP_BITS), .MAN_BITS(MAN_BITS), .SHIFT_DSP(ADD_DSP)) u_sub (
        .clk, .rst, .in_valid, .a, .b, .sub(1'b1), .out_valid(sub_valid), .y(sub_y), .flags(sub_flags)
    );
    fp_mul #(.EXP_BITS(EXP_BITS), .MAN_BITS(MAN_BITS)) u_mul (
        .clk, .rst, .in_valid, .a, .b, .out_valid(mul_valid), .y(mul_y), .flags(mul_flags)
    );
    fp_div #(.EXP_BITS(EXP_BITS), .MAN_BITS(MAN_BITS)) u_div (
        .clk, .rst, .in_valid, .a, .b, .out_valid(div_valid), .y(div_y), .flags(div_flags)
    );
    fp_sqrt #(.EXP_BITS(EXP_BITS), .MAN_BITS(MAN_BITS)) u_sqrt (
        .clk, .rst, .in_valid, .a, .out_valid(sqrt_valid), .y(sqrt_y), .flags(sqrt_flags)
    );
    fp_minmax #(.EXP_BITS(EXP_BITS), .MAN_BITS(MAN_BITS), .LATENCY(MINMAX_LATENCY)) u_minmax (
        .clk, .rst, .in_valid, .a, .b, .out_valid(mm_valid), .y_min(min_y), .y_max(max_y),
        .lt(cmp_flags[0]), .eq(cmp_flags[1]), .unordered(cmp_flags[2])
    );

    assign fmt_width  = 8'(W);
    assign lat_add    = 8'(u_add.LATENCY);
    assign lat_mul    = 8'(u_mul.LATENCY);
    assign lat_div    = 8'(u_div.LATENCY);
    assign lat_sqrt   = 8'(u_sqrt.LATENCY);
    assign lat_minmax = 8'(u_minmax.LATENCY);
endmodule

`default_nettype wire
