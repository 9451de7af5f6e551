// pgs_body_ram: the on-chip body table (per body: pos(3), q(4), v(3), w(3), mInv(1), IInv(IINV_W) words,
// the body-in record's word order; IINV_W = 1, 3 or 6, the inverse-inertia mode), with PORTS registered read ports and PORTS write ports per cycle
// (bodies A and B of each issue lane's manifold: PORTS = 2 x lanes), plus two flags per body with
// asynchronous read for the issue-time checks: "dynamic" (hazard tracking, retire writes) and "bad" (a
// rejected body-in record: frozen, every manifold naming it is rejected, integration passes it through).
//
// Port k (flat vectors, port k at bits [k*width +: width]): rd_addr -> rd_data one cycle later
// (read-before-write: a read of an address written in the same cycle returns the old value; the kernel's
// hazard CAM never lets that happen for a body in flight). wr_en with, on port 0 only, wr0_full = 1 writes a
// whole (14 + IINV_W)-word record (body load; also sets the dynamic flag = the exponent of mInv is nonzero, i.e. a
// nonzero mInv after flush-to-zero, and not wr0_bad; and the bad flag = wr0_bad); otherwise a write
// stores only the velocity words v, w (7..12) of wr_data (solver retire). No two write ports address the
// same body in one cycle (a manifold's A and B differ: the kernel rejects a record naming one body twice,
// and the manifolds of one issue are body-disjoint: it rejects a lane that shares a dynamic body with an
// earlier lane). rd0_bad is the bad flag of port 0's read address, registered like its data.
//
// This model is behavioural (PORTS write ports into one array). A board build would split it:
//  * the constant part (pos, q, mInv, IInv; written only at load) in block RAM replicated per read
//    port (PORTS copies, 1W1R each);
//  * the velocity part (v, w; 6 words) as a PORTS-write PORTS-read memory built from PORTS x PORTS banks
//    (one per write port x read port, each 1W1R block RAM) and a live-value table (LVT: log2(PORTS) bits per
//    body in distributed RAM, recording which write port wrote a body last; a read selects that bank's
//    word). With PORTS = 2, MAX_BODIES = 65536 x 6 x 32 bit = 12.6 Mbit for fp32 per bank: the four banks
//    take ~1.5 k BRAM36 / 384 URAM for the full 65536 bodies (the thesis's 38,880 bodies fit a 48 k-entry
//    variant); PORTS = 4 needs 16 banks (URAM on an Alveo-class part);
//  * the dynamic and bad flags in distributed RAM (2 bits x MAX_BODIES, asynchronous read).
// BODY_BANKS > 0 replaces the behavioural velocity part by pgs_body_vel_banks (PORTS reads enabled by rd_en): one copy of the
// velocities in BODY_BANKS true dual-port banks (body k in bank k mod BODY_BANKS); `busy` is high in a cycle in
// which a bank is asked for more than its two ports (the writes served first, a read then goes unserved): the
// sequencer issues no record then. BODY_BANKS = 0: `busy` is always low.
`default_nettype none

module pgs_body_ram #(
    parameter int EXP_BITS   = 8,
    parameter int MAN_BITS   = 23,
    parameter int MAX_BODIES = 65536,
    parameter int PORTS      = 2,
    parameter int IINV_W     = 3,
    parameter int BODY_BANKS = 0,      // 0: the velocities as one multiport array; > 0: banked
    localparam int W         = 1 + EXP_BITS + MAN_BITS,
    localparam int REC_W     = (14 + IINV_W) * W,
    localparam int IDX_W     = $clog2(MAX_BODIES)
) (
    input  wire                    clk,
    input  wire  [PORTS-1:0]       rd_en,     // BODY_BANKS > 0: the reads the banks must serve this cycle
    input  wire  [PORTS*IDX_W-1:0] rd_addr,
    output logic [PORTS*REC_W-1:0] rd_data,
    output logic                   rd0_bad,
    input  wire  [PORTS-1:0]       wr_en,
    input  wire                    wr0_full,
    input  wire                    wr0_bad,
    input  wire  [PORTS*IDX_W-1:0] wr_addr,
    input  wire  [PORTS*REC_W-1:0] wr_data,
    input  wire  [PORTS*IDX_W-1:0] dyn_addr,
    output logic [PORTS-1:0]       dyn,
    output logic [PORTS-1:0]       bad,
    output logic                   busy
);
    // words 0..6 (pos, q) and 13 .. 13 + IINV_W (mInv, IInv): constant during a step; 7..12 (v, w): velocities
    localparam int FIX_W = (8 + IINV_W) * W;
    localparam int VEL_W = 6 * W;

    logic [FIX_W-1:0] mem_fix [MAX_BODIES];
    logic             mem_dyn [MAX_BODIES];
    logic             mem_bad [MAX_BODIES];

    wire [IDX_W-1:0] wr0_addr = wr_addr[0 +: IDX_W];
    wire [FIX_W-1:0] wr0_fix  = {wr_data[REC_W-1:13*W], wr_data[7*W-1:0]};
    wire             wr0_dyn  = wr_data[13*W + MAN_BITS +: EXP_BITS] != '0 && !wr0_bad;

    always_ff @(posedge clk) begin
        if (wr_en[0] && wr0_full) begin
            mem_fix[wr0_addr] <= wr0_fix;
            mem_dyn[wr0_addr] <= wr0_dyn;
            mem_bad[wr0_addr] <= wr0_bad;
        end
    end

    logic [FIX_W-1:0] q_fix [PORTS];
    logic [VEL_W-1:0] q_vel [PORTS];
    always_ff @(posedge clk) begin
        for (int k = 0; k < PORTS; k++) q_fix[k] <= mem_fix[rd_addr[k*IDX_W +: IDX_W]];
        rd0_bad <= mem_bad[rd_addr[0 +: IDX_W]];
    end

    // the velocity words of each port's write
    logic [PORTS*VEL_W-1:0] wr_vel;
    always_comb begin
        for (int k = 0; k < PORTS; k++) wr_vel[k*VEL_W +: VEL_W] = wr_data[k*REC_W + 7*W +: VEL_W];
    end
    generate
        if (BODY_BANKS > 0) begin : g_banked
            logic [PORTS*VEL_W-1:0] rd_vel;
            pgs_body_vel_banks #(.VEL_W(VEL_W), .MAX_BODIES(MAX_BODIES), .BANKS(BODY_BANKS), .PORTS(PORTS)) u_vel (
                .clk, .rd_en, .rd_addr, .rd_data(rd_vel), .wr_en, .wr_addr, .wr_data(wr_vel), .busy);
            always_comb begin
                for (int k = 0; k < PORTS; k++) q_vel[k] = rd_vel[k*VEL_W +: VEL_W];
            end
        end else begin : g_multiport
            logic [VEL_W-1:0] mem_vel [MAX_BODIES];
            always_ff @(posedge clk) begin
                for (int k = 0; k < PORTS; k++) begin
                    if (wr_en[k]) mem_vel[wr_addr[k*IDX_W +: IDX_W]] <= wr_vel[k*VEL_W +: VEL_W];
                    q_vel[k] <= mem_vel[rd_addr[k*IDX_W +: IDX_W]];
                end
            end
            assign busy = 1'b0;
            wire unused_rd_en = ^rd_en;   // every read is served
        end
    endgenerate
    always_comb begin
        for (int k = 0; k < PORTS; k++) begin
            rd_data[k*REC_W +: REC_W] = {q_fix[k][FIX_W-1:7*W], q_vel[k], q_fix[k][7*W-1:0]};
            dyn[k] = mem_dyn[dyn_addr[k*IDX_W +: IDX_W]];
            bad[k] = mem_bad[dyn_addr[k*IDX_W +: IDX_W]];
        end
    end
    // Not needed: the words other than the velocities of the ports that write velocities only (all but 0).
    logic unused_wr;
    always_comb begin
        unused_wr = 1'b0;
        for (int k = 1; k < PORTS; k++) unused_wr ^= ^{wr_data[k*REC_W +: 7*W], wr_data[k*REC_W + 13*W +: (1 + IINV_W)*W]};
    end
endmodule

`default_nettype wire
