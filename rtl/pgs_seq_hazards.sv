// pgs_seq_hazards: whether the record offered may issue as far as the manifolds in flight go (pgs_sequencer).
//
// `cand` is the offered record's bodies (lane l's A at port 2l, B at 2l + 1: also the body RAM's read addresses, whose
// flags come back as `dyn`); the lanes that would issue (l_go) enter their dynamic bodies into the hazard CAM
// (pgs_hazard_cam, HAZARD_DEPTH issues in flight) at `issue`, and the oldest issue leaves at `retire`. `may_issue` when
// no issuing lane's dynamic body is in flight (`hazard` clear; an entry counts up to its retire cycle inclusive), the CAM
// has room, no body-velocity bank is busy with the retire (body_busy, BODY_BANKS > 0) and -- with two pipes per lane on
// the streaming kernel (SHARED_DATAPATH = 0, WINDOW = 0) -- the record is of the kind issued last or every manifold has
// retired (the other pipe drained: retire stays in issue order). `drained` (the CAM empty): every issue has retired.
// `init` (the sequencer idle) makes the next step's first record a contact record's successor.
`default_nettype none

module pgs_seq_hazards #(
    parameter int MAX_BODIES      = 65536,
    parameter int HAZARD_DEPTH    = 256,
    parameter int LANES           = 1,
    parameter int WINDOW          = 0,
    parameter bit SHARED_DATAPATH = 1'b1,
    localparam int IDX_W          = $clog2(MAX_BODIES)
) (
    input  wire logic                     clk,
    input  wire logic                     rst,
    input  wire logic                     init,
    input  wire logic [LANES*IDX_W-1:0]   la,
    input  wire logic [LANES*IDX_W-1:0]   lb,
    input  wire logic [2*LANES-1:0]       dyn,
    input  wire logic [LANES-1:0]         l_go,
    input  wire logic                     kind,       // the offered record's pass kind
    input  wire logic                     issue,
    input  wire logic                     retire,
    input  wire logic                     body_busy,
    output logic      [2*LANES*IDX_W-1:0] cand,
    output logic                          hazard,
    output logic                          may_issue,
    output logic                          drained
);
    logic [2*LANES-1:0] cand_dyn;
    always_comb begin
        for (int l = 0; l < LANES; l++) begin
            cand[2*l*IDX_W +: IDX_W]     = la[l*IDX_W +: IDX_W];
            cand[(2*l+1)*IDX_W +: IDX_W] = lb[l*IDX_W +: IDX_W];
            cand_dyn[2*l]   = dyn[2*l] && l_go[l];
            cand_dyn[2*l+1] = dyn[2*l+1] && l_go[l];
        end
    end
    logic cam_full;
    pgs_hazard_cam #(.IDX_W(IDX_W), .DEPTH(HAZARD_DEPTH), .NB(2*LANES)) u_cam (
        .clk, .rst, .cand, .cand_dyn, .hazard, .push(issue), .pop(retire), .full(cam_full), .empty(drained));

    // two pipes per lane on the streaming kernel: the kind issued last (the shared datapath takes both kinds at one
    // latency, the window kernel aligns the two pipes' latencies)
    localparam bit DRAINS = !SHARED_DATAPATH && WINDOW == 0;
    logic last_kind;
    always_ff @(posedge clk) begin
        if (init) last_kind <= pgs_seq_pkg::CONTACT;
        else if (issue) last_kind <= kind;
    end
    assign may_issue = !hazard && !cam_full && (!DRAINS || kind == last_kind || drained) && !body_busy;
endmodule

`default_nettype wire
