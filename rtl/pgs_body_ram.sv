// pgs_body_ram: the on-chip body table (per body: pos(3), q(4), v(3), w(3), mInv(1), IInv(3) words,
// the body-in record's word order), with two registered read ports and two write ports per cycle
// (bodies A and B of a manifold), plus two flags per body with asynchronous read for the issue-time
// checks: "dynamic" (hazard tracking, retire writes) and "bad" (a rejected body-in record: frozen,
// every manifold naming it is rejected, integration passes it through).
//
// Ports: rd{0,1}_addr -> rd{0,1}_data one cycle later (read-before-write: a read of an address written
// in the same cycle returns the old value; the kernel's hazard CAM never lets that happen for a body
// in flight). wr{0,1}_en with wr{0,1}_full = 1 writes a whole 17-word record (body load; also sets the
// dynamic flag = the exponent of mInv is nonzero, i.e. a nonzero mInv after flush-to-zero, and not
// wr{0,1}_bad; and the bad flag = wr{0,1}_bad), with wr{0,1}_full = 0 only the velocity words v, w
// (7..12) of wr{0,1}_data (solver retire). The two write ports never address the same body in one
// cycle (a manifold's A and B differ: the kernel rejects a record naming one body twice). rd0_bad is
// the bad flag of rd0_addr, registered like rd0_data.
//
// This model is behavioural (two write ports into one array). A board build would split it:
//  * the constant part (pos, q, mInv, IInv; written only at load) in block RAM replicated per read
//    port (2 copies, 1W2R each);
//  * the velocity part (v, w; 6 words) as a 2W2R memory built from 4 banks (one per write port x read
//    port, each 1W1R block RAM) and a live-value table (LVT: 1 bit per body, in distributed RAM,
//    recording which write port wrote a body last; a read selects that bank's word). MAX_BODIES =
//    65536 x 6 x 32 bit = 12.6 Mbit for fp32 per bank set: the four banks take ~1.5 k BRAM36 / 384 URAM
//    for the full 65536 bodies (the thesis's 38,880 bodies fit a 48 k-entry variant);
//  * the dynamic and bad flags in distributed RAM (2 bits x MAX_BODIES, asynchronous read).
`default_nettype none

module pgs_body_ram #(
    parameter int EXP_BITS   = 8,
    parameter int MAN_BITS   = 23,
    parameter int MAX_BODIES = 65536,
    localparam int W         = 1 + EXP_BITS + MAN_BITS,
    localparam int REC_W     = 17 * W,
    localparam int IDX_W     = $clog2(MAX_BODIES)
) (
    input  wire              clk,
    input  wire  [IDX_W-1:0] rd0_addr,
    output logic [REC_W-1:0] rd0_data,
    output logic             rd0_bad,
    input  wire  [IDX_W-1:0] rd1_addr,
    output logic [REC_W-1:0] rd1_data,
    input  wire              wr0_en,
    input  wire              wr0_full,
    input  wire              wr0_bad,
    input  wire  [IDX_W-1:0] wr0_addr,
    input  wire  [REC_W-1:0] wr0_data,
    input  wire              wr1_en,
    input  wire              wr1_full,
    input  wire              wr1_bad,
    input  wire  [IDX_W-1:0] wr1_addr,
    input  wire  [REC_W-1:0] wr1_data,
    input  wire  [IDX_W-1:0] dyn0_addr,
    output logic             dyn0,
    output logic             bad0,
    input  wire  [IDX_W-1:0] dyn1_addr,
    output logic             dyn1,
    output logic             bad1
);
    // words 0..6 (pos, q) and 13..16 (mInv, IInv): constant during a step; 7..12 (v, w): velocities
    localparam int FIX_W = 11 * W;
    localparam int VEL_W = 6 * W;

    logic [FIX_W-1:0] mem_fix [MAX_BODIES];
    logic [VEL_W-1:0] mem_vel [MAX_BODIES];
    logic             mem_dyn [MAX_BODIES];
    logic             mem_bad [MAX_BODIES];

    wire [FIX_W-1:0] wr0_fix = {wr0_data[REC_W-1:13*W], wr0_data[7*W-1:0]};
    wire [FIX_W-1:0] wr1_fix = {wr1_data[REC_W-1:13*W], wr1_data[7*W-1:0]};
    wire             wr0_dyn = wr0_data[13*W + MAN_BITS +: EXP_BITS] != '0 && !wr0_bad;
    wire             wr1_dyn = wr1_data[13*W + MAN_BITS +: EXP_BITS] != '0 && !wr1_bad;

    always_ff @(posedge clk) begin
        if (wr0_en) begin
            mem_vel[wr0_addr] <= wr0_data[7*W +: VEL_W];
            if (wr0_full) begin
                mem_fix[wr0_addr] <= wr0_fix;
                mem_dyn[wr0_addr] <= wr0_dyn;
                mem_bad[wr0_addr] <= wr0_bad;
            end
        end
        if (wr1_en) begin
            mem_vel[wr1_addr] <= wr1_data[7*W +: VEL_W];
            if (wr1_full) begin
                mem_fix[wr1_addr] <= wr1_fix;
                mem_dyn[wr1_addr] <= wr1_dyn;
                mem_bad[wr1_addr] <= wr1_bad;
            end
        end
    end

    logic [FIX_W-1:0] q0_fix, q1_fix;
    logic [VEL_W-1:0] q0_vel, q1_vel;
    always_ff @(posedge clk) begin
        q0_fix <= mem_fix[rd0_addr];
        q0_vel <= mem_vel[rd0_addr];
        rd0_bad <= mem_bad[rd0_addr];
        q1_fix <= mem_fix[rd1_addr];
        q1_vel <= mem_vel[rd1_addr];
    end
    assign rd0_data = {q0_fix[FIX_W-1:7*W], q0_vel, q0_fix[7*W-1:0]};
    assign rd1_data = {q1_fix[FIX_W-1:7*W], q1_vel, q1_fix[7*W-1:0]};

    assign dyn0 = mem_dyn[dyn0_addr];
    assign dyn1 = mem_dyn[dyn1_addr];
    assign bad0 = mem_bad[dyn0_addr];
    assign bad1 = mem_bad[dyn1_addr];
endmodule

`default_nettype wire
