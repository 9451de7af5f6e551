// fp_data_pipe: the data shift register of a fixed-latency pipeline.
//
// q is d delayed by DEPTH (>= 1) clock cycles. Free-running: no reset and no enable (the operators
// reset only their valid pipeline, fp_valid_pipe). Used for what an operator carries unchanged from
// one stage to a later one (exception side band, exponent) and for fp_minmax's output stages.
// Exceptions: none. Latency: DEPTH.
`default_nettype none

module fp_data_pipe #(
    parameter int WIDTH = 1,
    parameter int DEPTH = 1
) (
    input  wire logic             clk,
    input  wire logic [WIDTH-1:0] d,
    output logic      [WIDTH-1:0] q
);
    logic [WIDTH-1:0] stage_q [DEPTH];   // stage_q[i]: d delayed by i + 1 cycles

    always_ff @(posedge clk) begin
        stage_q[0] <= d;
        for (int i = 1; i < DEPTH; i++) stage_q[i] <= stage_q[i-1];
    end

    assign q = stage_q[DEPTH-1];
endmodule

`default_nettype wire
