// pgs_error_flags: the error codes of pgs_sequencer (pgs_regs_pkg ERR_*, rtl/README.md "Bad input").
//
// Each input is the condition of one code this cycle; err_set has flag bit k-1 set for each code k
// raised, err_code names the lowest one raised (0: none). Combinational.
`default_nettype none

module pgs_error_flags (
    input  wire        cons_tlast,      // a constraint record cut short or a missing TLAST
    input  wire        body_tlast,      // a body-in record cut short, an early or a missing TLAST
    input  wire        bad_args,        // a bad argument at start
    input  wire        body_index,      // a body index out of range, or a body named twice
    input  wire        non_finite,      // a non-finite word in a record
    input  wire        negative_mass,   // a negative inverse mass or inertia
    input  wire        static_pair,     // a constraint between two static bodies
    output logic [7:0] err_set,
    output logic [7:0] err_code
);
    logic [6:0] err_hit;
    always_comb begin
        err_hit[pgs_regs_pkg::ERR_CONS_TLAST - 1]    = cons_tlast;
        err_hit[pgs_regs_pkg::ERR_BODY_TLAST - 1]    = body_tlast;
        err_hit[pgs_regs_pkg::ERR_BAD_ARGS - 1]      = bad_args;
        err_hit[pgs_regs_pkg::ERR_BODY_INDEX - 1]    = body_index;
        err_hit[pgs_regs_pkg::ERR_NON_FINITE - 1]    = non_finite;
        err_hit[pgs_regs_pkg::ERR_NEGATIVE_MASS - 1] = negative_mass;
        err_hit[pgs_regs_pkg::ERR_STATIC_PAIR - 1]   = static_pair;
        err_set  = {1'b0, err_hit};
        err_code = 8'h00;
        for (int k = 6; k >= 0; k--) begin
            if (err_hit[k]) err_code = 8'(k + 1);
        end
    end
endmodule

`default_nettype wire
