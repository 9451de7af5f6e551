// pgs_impulse_ram: accumulated impulses per manifold slot (lam[0..3] normal, lamT[0..1] friction),
// kept on chip across the passes of a step.
//
// One registered read port (rd_addr -> rd_lam/rd_lamT one cycle later) and one write port with
// separate enables for the lam and lamT fields (a contact retire writes lam, a friction retire lamT).
// "Zeroed at the start of the step" costs no cycles: the kernel raises rd_zero_lam on the reads of the
// first contact pass and rd_zero_lamT on the reads of the first friction pass of a step (the first
// reads of each field in that step, before any write of it), and the port then returns +0 words
// instead of the stored ones; the retire of that pass overwrites every slot in use. Behavioural
// 1R1W array; a board build maps it to block/ultra RAM (MAX_MANIFOLDS = 262144 x 6 words).
`default_nettype none

module pgs_impulse_ram #(
    parameter int EXP_BITS      = 8,
    parameter int MAN_BITS      = 23,
    parameter int MAX_MANIFOLDS = 262144,
    localparam int W            = 1 + EXP_BITS + MAN_BITS,
    localparam int SLOT_W       = $clog2(MAX_MANIFOLDS)
) (
    input  wire               clk,
    input  wire  [SLOT_W-1:0] rd_addr,
    input  wire               rd_zero_lam,
    input  wire               rd_zero_lamT,
    output logic [4*W-1:0]    rd_lam,
    output logic [2*W-1:0]    rd_lamT,
    input  wire  [SLOT_W-1:0] wr_addr,
    input  wire               wr_lam_en,
    input  wire  [4*W-1:0]    wr_lam,
    input  wire               wr_lamT_en,
    input  wire  [2*W-1:0]    wr_lamT
);
    logic [4*W-1:0] mem_lam  [MAX_MANIFOLDS];
    logic [2*W-1:0] mem_lamT [MAX_MANIFOLDS];

    always_ff @(posedge clk) begin
        if (wr_lam_en)  mem_lam[wr_addr]  <= wr_lam;
        if (wr_lamT_en) mem_lamT[wr_addr] <= wr_lamT;
    end

    logic [4*W-1:0] q_lam;
    logic [2*W-1:0] q_lamT;
    logic           q_zero_lam, q_zero_lamT;
    always_ff @(posedge clk) begin
        q_lam       <= mem_lam[rd_addr];
        q_lamT      <= mem_lamT[rd_addr];
        q_zero_lam  <= rd_zero_lam;
        q_zero_lamT <= rd_zero_lamT;
    end
    assign rd_lam  = q_zero_lam  ? '0 : q_lam;
    assign rd_lamT = q_zero_lamT ? '0 : q_lamT;
endmodule

`default_nettype wire
