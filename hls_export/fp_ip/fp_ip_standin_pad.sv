// fp_ip_standin_pad: the latency padding of a Floating-Point Operator stand-in (fp_ip_standin.sv): delays the
// rtl/fp operator's result (OP_LATENCY cycles after its operands) by C_LATENCY - OP_LATENCY more cycles of the
// gated clock, so that it leaves C_LATENCY cycles after its operands, like the Xilinx core configured with
// C_LATENCY. A C_LATENCY below OP_LATENCY cannot be met by padding: elaboration stops with an error naming
// both latencies (an elaboration-time $fatal, which Verilator reports as %Warning-USERFATAL and fails on; a
// build with -Wno-fatal, as a build of the generated HLS Verilog may need, gets the same message from an initial
// $fatal when the simulation starts).
// Latency: C_LATENCY - OP_LATENCY cycles of clk.
`default_nettype none

module fp_ip_standin_pad #(
    parameter string OPERATION  = "add",   // for the error message
    parameter int    WIDTH      = 32,
    parameter int    OP_LATENCY = 4,
    parameter int    C_LATENCY  = 4
) (
    /* verilator lint_off UNUSEDSIGNAL */
    input  wire logic             clk,   // unused only in the error branch (C_LATENCY too short)
    /* verilator lint_on UNUSEDSIGNAL */
    input  wire logic [WIDTH-1:0] d,
    output logic      [WIDTH-1:0] q
);
    if (C_LATENCY < OP_LATENCY) begin : g_too_short
        $fatal(1, "fp_ip_standin (%s): C_LATENCY = %0d is shorter than the latency of the rtl/fp operator (%0d %s",
               OPERATION, C_LATENCY, OP_LATENCY, "cycles); the stand-in can only add cycles");
        initial $fatal(1, "fp_ip_standin (%s): C_LATENCY = %0d is shorter than the latency of the rtl/fp %s (%0d %s",
                       OPERATION, C_LATENCY, "operator", OP_LATENCY, "cycles); the stand-in can only add cycles");
        assign q = d;
    end else begin : g_pad
        fp_ip_delay #(.WIDTH(WIDTH), .DEPTH(C_LATENCY - OP_LATENCY)) u_delay (.clk, .d, .q);
    end
endmodule

`default_nettype wire
