// The subcommands of the penumbra tool (DESIGN.md "The command-line contract").
#pragma once

#include <CLI/CLI.hpp>

namespace penumbra::cli {

void add_render_command(CLI::App& app);
void add_view_command(CLI::App& app);
void add_demo_command(CLI::App& app);
void add_compare_command(CLI::App& app);
void add_montage_command(CLI::App& app);
void add_info_command(CLI::App& app);
void add_bench_command(CLI::App& app);
void add_techniques_command(CLI::App& app);
void add_select_command(CLI::App& app);
void add_convert_command(CLI::App& app);

}  // namespace penumbra::cli
