// pgs_hazard_cam: the dynamic bodies of the manifolds in flight, and the issue-time hazard check.
//
// An issue (one manifold per lane, NB = 2 x lanes bodies: A and B of each) enters as one entry (push)
// when its bodies are read and leaves (pop) in the cycle its velocities are written back (retire);
// retire is in issue order (the streaming kernel drains the pipes before it switches between the
// contact and the friction pipe, the window kernel aligns their latencies; all lanes of an issue retire
// together), so the entries form a FIFO. While an entry is present -- including its retire cycle, whose
// write lands at the end of the cycle -- a candidate that names one of its dynamic bodies raises
// `hazard` and must not issue. Bodies flagged static (cand_dyn bit 0, or stored with it 0: static
// bodies and the bodies of lanes that do not issue) never match. `full` when DEPTH issues are in flight
// (issue must wait), `empty` when none is. Body k of the candidate / an entry is at bits [k*IDX_W +: IDX_W].
// DEPTH must be a power of two >= the longest issue-to-retire latency for full throughput (a smaller
// one only throttles issue). The comparison is NB x NB x DEPTH equality compares of IDX_W bits per cycle.
`default_nettype none

module pgs_hazard_cam #(
    parameter int IDX_W = 16,
    parameter int DEPTH = 256,
    parameter int NB    = 2,
    localparam int PTR_W = $clog2(DEPTH)
) (
    input  wire                clk,
    input  wire                rst,
    input  wire [NB*IDX_W-1:0] cand,
    input  wire [NB-1:0]       cand_dyn,
    output logic               hazard,
    input  wire                push,     // enter the candidate
    input  wire                pop,      // the oldest entry retires (written back at the end of this cycle)
    output logic               full,
    output logic               empty
);
    logic [NB*IDX_W-1:0] ent [DEPTH];
    logic [NB-1:0]       live [DEPTH];   // entry present and its body k dynamic
    logic [PTR_W-1:0]    wp, rp;
    logic [PTR_W:0]      count;

    always_ff @(posedge clk) begin
        if (push) ent[wp] <= cand;
    end

    always_ff @(posedge clk) begin
        if (rst) begin
            for (int i = 0; i < DEPTH; i++) live[i] <= '0;
            wp    <= '0;
            rp    <= '0;
            count <= '0;
        end else begin
            if (pop) begin
                live[rp] <= '0;
                rp       <= rp + 1'b1;
            end
            if (push) begin
                live[wp] <= cand_dyn;
                wp       <= wp + 1'b1;
            end
            count <= count + (PTR_W+1)'(push) - (PTR_W+1)'(pop);
        end
    end

    // each candidate body against every live body in flight; its dynamic flag gates the match at the end (the flag
    // comes from the issue checks, later in the cycle than the body indices). The hits are gathered in a vector and
    // reduced with one OR (a balanced tree in the elaborated netlist), not assigned one by one (a chain).
    logic [NB-1:0] match;
    always_comb begin
        for (int c = 0; c < NB; c++) begin
            automatic logic [DEPTH*NB-1:0] hit;
            for (int i = 0; i < DEPTH; i++)
                for (int e = 0; e < NB; e++)
                    hit[i*NB + e] = live[i][e] && ent[i][e*IDX_W +: IDX_W] == cand[c*IDX_W +: IDX_W];
            match[c] = |hit;
        end
    end
    assign hazard = (match & cand_dyn) != '0;
    assign full  = count == (PTR_W+1)'(DEPTH);
    assign empty = count == '0;
endmodule

`default_nettype wire
