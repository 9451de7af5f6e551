// pgs_hazard_cam: the dynamic bodies of the manifolds in flight, and the issue-time hazard check.
//
// A manifold enters (push) when it is issued (its bodies are read) and leaves (pop) in the cycle its
// velocities are written back (retire); retire is in issue order (the kernel drains the pipes
// before it switches between the contact and the friction pipe), so the entries form a FIFO. While an
// entry is present -- including its retire cycle, whose write lands at the end of the cycle -- a
// candidate manifold that names one of its dynamic bodies (as A or B) raises `hazard` and must not
// issue. Static bodies (cand_*_dyn = 0, or stored with dyn = 0) never match. `full` when DEPTH
// manifolds are in flight (issue must wait), `empty` when none is.
// DEPTH must be a power of two >= the longest issue-to-retire latency for full throughput (a smaller
// one only throttles issue). The comparison is 4 x DEPTH equality compares of IDX_W bits per cycle.
`default_nettype none

module pgs_hazard_cam #(
    parameter int IDX_W = 16,
    parameter int DEPTH = 256,
    localparam int PTR_W = $clog2(DEPTH)
) (
    input  wire             clk,
    input  wire             rst,
    input  wire [IDX_W-1:0] cand_a,
    input  wire             cand_a_dyn,
    input  wire [IDX_W-1:0] cand_b,
    input  wire             cand_b_dyn,
    output logic            hazard,
    input  wire             push,     // enter the candidate
    input  wire             pop,      // the oldest entry retires (written back at the end of this cycle)
    output logic            full,
    output logic            empty
);
    logic [IDX_W-1:0] ent_a [DEPTH];
    logic [IDX_W-1:0] ent_b [DEPTH];
    logic [DEPTH-1:0] live_a, live_b;   // entry present and its A / B body dynamic
    logic [PTR_W-1:0] wp, rp;
    logic [PTR_W:0]   count;

    always_ff @(posedge clk) begin
        if (push) begin
            ent_a[wp] <= cand_a;
            ent_b[wp] <= cand_b;
        end
    end

    always_ff @(posedge clk) begin
        if (rst) begin
            live_a <= '0;
            live_b <= '0;
            wp     <= '0;
            rp     <= '0;
            count  <= '0;
        end else begin
            if (pop) begin
                live_a[rp] <= 1'b0;
                live_b[rp] <= 1'b0;
                rp         <= rp + 1'b1;
            end
            if (push) begin
                live_a[wp] <= cand_a_dyn;
                live_b[wp] <= cand_b_dyn;
                wp         <= wp + 1'b1;
            end
            count <= count + (PTR_W+1)'(push) - (PTR_W+1)'(pop);
        end
    end

    always_comb begin
        hazard = 1'b0;
        for (int i = 0; i < DEPTH; i++) begin
            if (live_a[i] && ((cand_a_dyn && ent_a[i] == cand_a) || (cand_b_dyn && ent_a[i] == cand_b))) hazard = 1'b1;
            if (live_b[i] && ((cand_a_dyn && ent_b[i] == cand_a) || (cand_b_dyn && ent_b[i] == cand_b))) hazard = 1'b1;
        end
    end
    assign full  = count == (PTR_W+1)'(DEPTH);
    assign empty = count == '0;
endmodule

`default_nettype wire
