// pgs_body_vel_banks: the body velocities (v, w: VEL_W bits per body) as BANKS banks of true dual-port RAM,
// body k in bank k mod BANKS at row k / BANKS, each bank two ports per cycle (each a read or a write), the
// ports a board build's RAMB36E2 / URAM has. One copy of the table in all (the live-value table of
// pgs_body_ram's behavioural model needs PORTS x PORTS).
//
// Accesses per cycle: up to PORTS writes (wr_en[k], wr_addr[k], wr_data[k]: the dynamic bodies of the retiring
// manifold, or of its lanes' manifolds, or a load) and up to PORTS reads (rd_en[k], rd_addr[k]: bodies A and B of
// the offered record's issuing lanes, or the integration's body); PORTS = 2 x lanes. A bank serves its first two
// accesses in the order write 0 .. write PORTS-1, read 0 .. read PORTS-1; `busy` is high when some bank is asked
// for more than two, i.e. a read goes unserved. The writes always are served: a retire writes the dynamic bodies
// its issue read, and the sequencer issues no record whose lanes read some bank more than twice (one lane reads
// two bodies). The sequencer does not issue a record in a busy cycle (models/kernel/body_banks.py, the same rule for the
// cycle model). rd_data[k] one cycle after rd_addr[k], read-before-write as pgs_body_ram (the hazard CAM never
// lets a body in flight be read), meaningful only where `busy` was low and rd_en[k] high.
`default_nettype none

module pgs_body_vel_banks #(
    parameter int VEL_W      = 192,
    parameter int MAX_BODIES = 65536,
    parameter int BANKS      = 4,      // a power of two dividing MAX_BODIES
    parameter int PORTS      = 2,      // reads and writes a cycle: 2 x the sequencer's lanes
    localparam int IDX_W     = $clog2(MAX_BODIES),
    localparam int DEPTH     = MAX_BODIES / BANKS,
    localparam int ROW_W     = DEPTH > 1 ? $clog2(DEPTH) : 1
) (
    input  wire                    clk,
    input  wire  [PORTS-1:0]       rd_en,
    input  wire  [PORTS*IDX_W-1:0] rd_addr,
    output logic [PORTS*VEL_W-1:0] rd_data,
    input  wire  [PORTS-1:0]       wr_en,
    input  wire  [PORTS*IDX_W-1:0] wr_addr,
    input  wire  [PORTS*VEL_W-1:0] wr_data,
    output logic                   busy
);
    localparam int N_ACC = 2 * PORTS;   // accesses 0 .. PORTS-1: the writes; PORTS .. 2 PORTS-1: the reads
    localparam int SEL_W = $clog2(N_ACC);

    function automatic int bank_of(input logic [IDX_W-1:0] a);
        return int'(a) % BANKS;
    endfunction
    function automatic logic [ROW_W-1:0] row_of(input logic [IDX_W-1:0] a);
        return ROW_W'(int'(a) / BANKS);
    endfunction

    logic [IDX_W-1:0] acc_addr [N_ACC];
    logic             acc_on   [N_ACC];
    always_comb begin
        for (int j = 0; j < PORTS; j++) begin
            acc_addr[j]         = wr_addr[j*IDX_W +: IDX_W];
            acc_on[j]           = wr_en[j];
            acc_addr[PORTS + j] = rd_addr[j*IDX_W +: IDX_W];
            acc_on[PORTS + j]   = rd_en[j];
        end
    end

    // per bank: which access each port serves (p_on: the port is used), and the overflow
    logic [SEL_W-1:0] p_sel [BANKS][2];
    logic             p_on  [BANKS][2];
    logic [BANKS-1:0] over;
    always_comb begin
        for (int b = 0; b < BANKS; b++) begin
            automatic int n = 0;
            p_sel[b][0] = '0;
            p_sel[b][1] = '0;
            p_on[b][0]  = 1'b0;
            p_on[b][1]  = 1'b0;
            over[b]     = 1'b0;
            for (int j = 0; j < N_ACC; j++) begin
                if (acc_on[j] && bank_of(acc_addr[j]) == b) begin
                    if (n < 2) begin
                        p_sel[b][n] = SEL_W'(j);
                        p_on[b][n]  = 1'b1;
                    end else begin
                        over[b] = 1'b1;
                    end
                    n++;
                end
            end
        end
    end
    assign busy = over != '0;

    // the banks: two ports each, a write when the served access is a write, else a read
    logic [2*VEL_W-1:0] q [BANKS];   // bank b's port p at [p*VEL_W +: VEL_W]
    for (genvar b = 0; b < BANKS; b++) begin : g_bank
        logic [VEL_W-1:0] mem [DEPTH];
        logic [VEL_W-1:0] q_port [2];
        logic             we  [2];
        logic [ROW_W-1:0] row [2];
        logic [VEL_W-1:0] din [2];
        always_comb begin
            for (int p = 0; p < 2; p++) begin
                we[p]  = p_on[b][p] && int'(p_sel[b][p]) < PORTS;
                row[p] = row_of(acc_addr[p_sel[b][p]]);
                din[p] = wr_data[(int'(p_sel[b][p]) % PORTS)*VEL_W +: VEL_W];
            end
        end
        always_ff @(posedge clk) begin
            for (int p = 0; p < 2; p++) begin
                if (we[p]) mem[row[p]] <= din[p];
                else       q_port[p] <= mem[row[p]];
            end
        end
        assign q[b] = {q_port[1], q_port[0]};
    end

    // each read's bank and port, registered, select its data
    int          r_bank [PORTS];
    logic        r_port [PORTS];
    always_ff @(posedge clk) begin
        for (int k = 0; k < PORTS; k++) begin
            r_bank[k] <= bank_of(acc_addr[PORTS + k]);
            r_port[k] <= p_on[bank_of(acc_addr[PORTS + k])][1]
                         && p_sel[bank_of(acc_addr[PORTS + k])][1] == SEL_W'(PORTS + k);
        end
    end
    always_comb begin
        for (int k = 0; k < PORTS; k++) rd_data[k*VEL_W +: VEL_W] = q[r_bank[k]][32'(r_port[k])*VEL_W +: VEL_W];
    end
endmodule

`default_nettype wire
