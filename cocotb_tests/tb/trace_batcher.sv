// Collects the kernel's trace records into batches for the testbench, for transaction-level co-simulation.
//
// Every cycle with `valid` appends {cycle, data} (the record and the testbench cycle it retired in, SW = RW + 64
// bits) to the open batch, record k in bits [k*SW +: SW]; at BATCH records the batch closes and batch_seq
// changes. The testbench wakes once per batch, on that change, and reads `batch` in the same time step (the next
// record overwrites record 0 at the next clock edge); at the end it reads the `fill` records of the open batch.
`default_nettype none
module trace_batcher #(
    parameter int RW    = 576,
    parameter int BATCH = 16,
    localparam int SW   = RW + 64
) (
    input  wire                 clk,
    input  wire                 rst_n,
    input  wire                 valid,
    input  wire [RW-1:0]        data,
    input  wire [63:0]          cycle,
    output logic [BATCH*SW-1:0] batch,
    output logic [15:0]         fill,
    output logic [31:0]         batch_seq
);
    always_ff @(posedge clk) begin
        if (!rst_n) begin
            fill      <= '0;
            batch_seq <= '0;
        end else if (valid) begin
            batch[fill[$clog2(BATCH)-1:0]*SW +: SW] <= {cycle, data};
            if (fill == 16'(BATCH - 1)) begin
                fill      <= '0;
                batch_seq <= batch_seq + 32'd1;
            end else begin
                fill <= fill + 16'd1;
            end
        end
    end
endmodule
`default_nettype wire
