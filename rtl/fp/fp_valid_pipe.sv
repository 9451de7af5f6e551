// fp_valid_pipe: the valid shift register of a fixed-latency pipeline.
//
// out_valid is in_valid delayed by LATENCY (>= 1) clock cycles; a synchronous active-high reset
// clears every stage. These are the only reset flops of the fp operators (data registers are not
// reset). stage_valid[i] is in_valid delayed by i cycles (stage_valid[0] = in_valid): register
// stage i + 1 takes a new operation in this cycle when stage_valid[i] is 1, which is how the
// operators enable their data registers (a clock enable on a board; a skipped stage in
// simulation). Exceptions: none. Latency: LATENCY.
`default_nettype none

module fp_valid_pipe #(
    parameter int LATENCY = 1
) (
    input  wire logic               clk,
    input  wire logic               rst,
    input  wire logic               in_valid,
    output logic      [LATENCY:0]   stage_valid,   // [i]: in_valid i cycles ago
    output logic                    out_valid
);
    logic [LATENCY:1] valid_r;   // valid_r[i]: the i-th register stage holds an operation

    // one shift of the whole register (a simulator updates it in one step, not one per stage)
    always_ff @(posedge clk) begin
        if (rst) valid_r <= '0;
        else     valid_r <= LATENCY'({valid_r, in_valid});   // drops valid_r[LATENCY]
    end

    assign stage_valid = {valid_r, in_valid};
    assign out_valid   = valid_r[LATENCY];
endmodule

`default_nettype wire
