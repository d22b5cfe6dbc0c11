// `shprobe convert`: a probe file in, any format of formats/engine_export.h out, so that baking and
// exporting are separate steps. The output name and format follow bake's rule (settleFormatAndOutput).
#include "app/commands.h"
#include "app/parsed_option.h"
#include "common/error.h"
#include "common/output_file.h"
#include "formats/engine_export.h"
#include "formats/output_format.h"
#include "formats/probe_file.h"

#include <cstdio>

namespace shprobe {

namespace {

void checkProbeFits(const Probe& probe, const ExportFormat& format) {
    if (probe.coefficients.order > format.maxOrder && format.maxOrder < 3)
        throw Error(ErrorKind::Input, "--format " + std::string(format.name) + " holds orders 1 to " +
                                          std::to_string(format.maxOrder));
}

} // namespace

void addConvertOptions(CLI::App& command, ConvertOptions& options) {
    command
        .add_option("probe", options.input,
                    "Probe file: JSON or binary (.bin, one probe); - reads standard input")
        ->required();
    command
        .add_option("-o,--output", options.output,
                    "Output file (default: probe and the format's extension); - writes to standard output")
        ->check(nonEmptyName());
    addFormatOptions(command, options.format, options.mapSize, options.mirror);
}

void runConvert(const ConvertOptions& given) {
    ConvertOptions options = given;
    settleFormatAndOutput(options.format, options.output);
    const ExportFormat& format = *findExportFormat(options.format);
    requireFormatOptionsUsed(options.format, options.mapSize, options.mirror);
    requireMapSizeFits(options.format, options.mapSize);
    checkOutputPath(options.output, format.content);
    checkOutputsAreNotInputs({&options.output, 1}, {&options.input, 1});
    const Probe probe = readProbe(options.input);
    checkProbeFits(probe, format);

    ExportOptions exportOptions{.mapSize = options.mapSize, .mirror = options.mirror.value_or(true)};
    exportOptions.metadata.source = options.input == "-" ? "standard input" : options.input;
    exportOptions.metadata.sun = probe.sun;
    exportOptions.metadata.window = probe.window;
    format.write(options.output, probe.coefficients, exportOptions);

    FILE* report = reportStream(options.output);
    std::fprintf(report, "shprobe convert: %s -> %s (%s, order %d %s)\n", options.input.c_str(),
                 options.output.c_str(), format.name, probe.coefficients.order,
                 quantityName(probe.coefficients.quantity));
    if (probe.coefficients.order > format.maxOrder)
        std::fprintf(report, "  %s holds bands 0..%d; the probe's higher bands are not in it\n", format.name,
                     format.maxOrder - 1);
}

} // namespace shprobe
