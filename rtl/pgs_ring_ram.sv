// pgs_ring_ram: a simple dual-port memory of DEPTH words of WIDTH bits (one write port, one read port), the arrays
// of the window kernel's rings (pgs_window: the fetched records and their heads; pgs_sequencer: the impulse ring).
//
// SYNC_READ = 1: the read is registered (rd_en, rd_addr -> rd_data one cycle later; rd_data holds its value while
// rd_en is low): block RAM on a board (ram_style "block"). SYNC_READ = 0: the read is asynchronous (rd_data follows
// rd_addr in the same cycle; rd_en unused): distributed RAM (ram_style "distributed"). A read of the address
// written in the same cycle returns the old word (the kernel never does one: a ring entry is read only after the
// cycle it was written). No reset: the kernel reads only entries it wrote in the step.
`default_nettype none

module pgs_ring_ram #(
    parameter int WIDTH     = 64,
    parameter int DEPTH     = 1024,
    parameter bit SYNC_READ = 1'b1,
    localparam int AW       = DEPTH > 1 ? $clog2(DEPTH) : 1
) (
    input  wire              clk,
    input  wire              wr_en,
    input  wire  [AW-1:0]    wr_addr,
    input  wire  [WIDTH-1:0] wr_data,
    input  wire              rd_en,
    input  wire  [AW-1:0]    rd_addr,
    output logic [WIDTH-1:0] rd_data
);
    generate
        if (SYNC_READ) begin : g_block
            (* ram_style = "block" *) logic [WIDTH-1:0] mem [DEPTH];
            always_ff @(posedge clk) begin
                if (wr_en) mem[wr_addr] <= wr_data;
                if (rd_en) rd_data <= mem[rd_addr];
            end
        end else begin : g_distributed
            (* ram_style = "distributed" *) logic [WIDTH-1:0] mem [DEPTH];
            always_ff @(posedge clk) begin
                if (wr_en) mem[wr_addr] <= wr_data;
            end
            assign rd_data = mem[rd_addr];
            wire unused_rd_en = rd_en;
        end
    endgenerate
endmodule

`default_nettype wire
