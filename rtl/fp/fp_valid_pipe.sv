// fp_valid_pipe: the valid shift register of a fixed-latency pipeline.
//
// out_valid is in_valid delayed by LATENCY (>= 1) clock cycles; a synchronous active-high reset
// clears every stage. These are the only reset flops of the fp operators (data registers are not
// reset). Exceptions: none. Latency: LATENCY.
`default_nettype none

module fp_valid_pipe #(
    parameter int LATENCY = 1
) (
    input  wire logic clk,
    input  wire logic rst,
    input  wire logic in_valid,
    output logic      out_valid
);
    logic [LATENCY:0] valid_q;   // valid_q[i]: the i-th register stage holds an operation

    assign valid_q[0] = in_valid;

    for (genvar i = 1; i <= LATENCY; i++) begin : g_stage
        always_ff @(posedge clk) begin
            if (rst) valid_q[i] <= 1'b0;
            else     valid_q[i] <= valid_q[i-1];
        end
    end

    assign out_valid = valid_q[LATENCY];
endmodule

`default_nettype wire
