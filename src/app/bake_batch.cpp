// `shprobe bake` with --out-dir: every input to its own file, baked in chunks of as many maps as one
// GPU submission takes (or one by one on the CPU); bad inputs are reported and skipped.
#include "app/bake_steps.h"
#include "app/progress_line.h"
#include "app/stopwatch.h"
#include "common/counted.h"
#include "common/input_file.h"
#include "common/output_file.h"
#include "common/scope_exit.h"

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <filesystem>
#include <future>
#include <map>
#include <sstream>
#include <sys/stat.h>
#include <unistd.h>

namespace shprobe {

namespace {

namespace fs = std::filesystem;

struct BatchItem {
    std::string input;
    std::string output;
};

// A list of a million paths is a few tens of megabytes; a larger file (or /dev/zero) is no list.
constexpr uint64_t kMaxListBytes = uint64_t(64) << 20;

// Paths as given on the command line, one a line; blank lines and '#' comments are skipped.
std::vector<std::string> readInputList(const std::string& path) {
    std::string text;
    try {
        text = readInputFile(path, kMaxListBytes, "a list of inputs");
    } catch (const Error& error) {
        throw Error(ErrorKind::Input, std::string("--list ") + error.what());
    }
    // A list saved by an editor that marks UTF-8: the mark is no part of the first path.
    if (text.starts_with("\xEF\xBB\xBF")) text.erase(0, 3);
    std::istringstream in(text);
    std::vector<std::string> inputs;
    int number = 0;
    for (std::string line; std::getline(in, line);) {
        ++number;
        // No path holds a NUL byte: the file is something else (an image, say), whose bytes would
        // otherwise be taken for names and their outputs' names cut short.
        if (line.find('\0') != std::string::npos)
            throw Error(ErrorKind::Input, "--list " + path + ": line " + std::to_string(number) +
                                              " holds a NUL byte, which no path does; a list holds one "
                                              "input's path a line");
        size_t first = line.find_first_not_of(" \t\r");
        if (first == std::string::npos || line[first] == '#') continue;
        size_t last = line.find_last_not_of(" \t\r");
        inputs.push_back(line.substr(first, last - first + 1));
    }
    return inputs;
}

// The name an input's output takes: the file's stem; a faces folder's own name; a {face} pattern's
// name without {face} and the separators around it (sky_{face}.exr -> sky), or its folder's name.
std::string outputStem(const std::string& input) {
    std::error_code error; // a relative input once the working folder is gone: named as given
    fs::path path = fs::absolute(input, error);
    path = (error ? fs::path(input) : path).lexically_normal();
    if (!path.has_filename()) path = path.parent_path();
    std::string stem = fs::is_directory(path, error) ? path.filename().string() : path.stem().string();
    if (size_t at = stem.find("{face}"); at != std::string::npos) {
        stem.erase(at, 6);
        size_t first = stem.find_first_not_of("_-. "), last = stem.find_last_not_of("_-. ");
        stem = first == std::string::npos ? path.parent_path().filename().string()
                                          : stem.substr(first, last - first + 1);
    }
    return stem.empty() ? "probe" : stem;
}

// Inputs and their outputs; two inputs with one output name are refused, naming both.
std::vector<BatchItem> planBatch(const BakeOptions& options) {
    std::vector<std::string> inputs = options.inputs;
    if (!options.listFile.empty()) {
        std::vector<std::string> listed = readInputList(options.listFile);
        inputs.insert(inputs.end(), listed.begin(), listed.end());
    }
    if (inputs.empty())
        throw Error(ErrorKind::Input,
                    "--out-dir: no inputs (give image files, or --list FILE with at least one)");
    std::vector<BatchItem> items;
    std::map<std::string, std::string> inputOf; // output -> input
    for (const std::string& input : inputs) {
        std::string output =
            (fs::path(options.outDir) / (outputStem(input) + formatExtension(options.format))).string();
        auto [at, fresh] = inputOf.emplace(output, input);
        if (!fresh)
            throw Error(ErrorKind::Input, "inputs " + at->second + " and " + input +
                                              " would both be written to " + output +
                                              "; rename one or bake them separately");
        items.push_back({input, output});
    }
    return items;
}

// The output folder is created when its parent exists; it and every output path are checked here,
// before any GPU work, so that a bake is never wasted on an output that cannot be written, and
// no output may be one of the inputs. Returns whether it created the folder.
bool prepareOutputFolder(const BakeOptions& options, const std::vector<BatchItem>& items) {
    const std::string& folder = options.outDir;
    const bool created = mkdir(folder.c_str(), 0777) == 0;
    if (!created && errno != EEXIST) {
        const int error = errno;
        const std::string parent = fs::path(folder).lexically_normal().parent_path().string();
        struct stat status {};
        // ENOENT where the parent exists: a file system that takes no new folders (/proc).
        if (error != ENOENT || stat(parent.empty() ? "." : parent.c_str(), &status) == 0)
            throw Error(ErrorKind::Output, "cannot create " + folder + ": " + systemReason(error));
        throw Error(ErrorKind::Output, "cannot write to " + folder + ": folder " +
                                           (parent.empty() ? "." : parent) + " does not exist");
    }
    // A folder made here is not left behind by a refusal below.
    OnFailure removeMade([&] {
        if (created) rmdir(folder.c_str());
    });
    struct stat status {};
    if (stat(folder.c_str(), &status) != 0)
        throw Error(ErrorKind::Output, "cannot write to " + folder + ": " + systemReason(errno));
    if (!S_ISDIR(status.st_mode))
        throw Error(ErrorKind::Output, "cannot write to " + folder + ": it is not a folder");
    // The list counts too: read already, it would still be lost under a probe.
    std::vector<std::string> outputs, inputs{options.listFile};
    for (const BatchItem& item : items) {
        checkOutputPath(item.output, formatContent(options.format));
        outputs.push_back(item.output);
        for (std::string& file : filesReadBy(item.input))
            inputs.push_back(std::move(file));
    }
    checkOutputsAreNotInputs(outputs, inputs);
    return created;
}

struct Batch {
    const BakeOptions& options;
    ProgressLine progress; // a bar: "[#####-----] 12/40 probes, ..."
    size_t processed = 0;  // baked or failed
    size_t baked = 0;
    size_t failed = 0;
    bool inputFailed = false;  // an input error among the failures (exit code 2)
    bool memoryFailed = false; // else an input too large for the machine's memory (exit code 1), else 3
    uint64_t texels = 0;
    size_t submissions = 0;
    bool gpu = false; // baked with Vulkan (the summary counts the submissions)
};

// A line on stdout or stderr between redraws of the progress bar.
void printLine(Batch& batch, FILE* stream, const std::string& line) {
    batch.progress.clear();
    std::fprintf(stream, "%s\n", line.c_str());
    std::fflush(stream);
    batch.progress.redraw();
}

void reportFailure(Batch& batch, const BatchItem& item, const Error& error) {
    std::string message = error.what();
    if (message.find(item.input) == std::string::npos) message = item.input + ": " + message;
    ++batch.failed;
    batch.inputFailed = batch.inputFailed || error.kind() == ErrorKind::Input;
    batch.memoryFailed = batch.memoryFailed || error.kind() == ErrorKind::Memory;
    batch.progress.update(++batch.processed);
    printLine(batch, stderr, "shprobe: error: " + message);
}

// An input as loaded, or why it could not be: a failure is reported in its turn among the others.
struct Loaded {
    const BatchItem* item = nullptr;
    Environment environment;
    std::optional<ProbeSun> sun;
    std::optional<Error> failure;
};

// Loads the inputs in order, one ahead: when an input is taken, the next starts loading on a thread
// of its own, so that decoding it overlaps baking and writing this one. Where no thread can be
// started, std::async loads on the calling thread when the input is taken. A failure
// that ends the batch waits for the load in flight (its future's destructor) before it is reported.
class InputLoader {
  public:
    InputLoader(const BakeOptions& options, const std::vector<BatchItem>& items)
        : options_(options), items_(items) {
        start();
    }
    InputLoader(const InputLoader&) = delete;
    InputLoader& operator=(const InputLoader&) = delete;

    bool done() const { return !pending_.valid(); }

    // The next input; a bad input, or one too large for the machine's memory, comes with its failure
    // (to be reported and skipped); any other failure ends the batch.
    Loaded next() {
        std::future<Loaded> loading = std::move(pending_);
        const BatchItem& item = items_[next_ - 1];
        start();
        try {
            return loading.get();
        } catch (const Error& error) {
            if (error.kind() != ErrorKind::Input && error.kind() != ErrorKind::Memory) throw;
            return {&item, {}, std::nullopt, error};
        }
    }

  private:
    void start() {
        if (next_ == items_.size()) return;
        const BatchItem& item = items_[next_++];
        pending_ = std::async(std::launch::async | std::launch::deferred, [this, &item] {
            Loaded loaded{&item, loadInput(options_, item.input), std::nullopt};
            loaded.sun = takeOutSun(options_, loaded.environment);
            return loaded;
        });
    }

    const BakeOptions& options_;
    const std::vector<BatchItem>& items_;
    size_t next_ = 0;
    std::future<Loaded> pending_;
};

void writeItem(Batch& batch, const Backend& backend, const Loaded& loaded, const BakeResult& result) {
    const BakeOptions& options = batch.options;
    try {
        requireUsable(backend, result, options.irradiance, loaded.environment.description);
    } catch (const Error& error) {
        reportFailure(batch, *loaded.item, error);
        return;
    }
    const ShCoefficients& written = options.irradiance ? result.irradiance : result.radiance;
    try {
        writeOutput(options, loaded.item->output, written,
                    metadataFor(backend, options, loaded.environment, result, loaded.sun),
                    loaded.environment);
    } catch (const Error& error) {
        if (error.kind() != ErrorKind::Output) throw;
        reportFailure(batch, *loaded.item, error);
        return;
    }
    ++batch.baked;
    batch.progress.update(++batch.processed);
    batch.texels += loaded.environment.texelCount();
    if (options.quiet) return;
    std::string line = "  " + loaded.environment.description + " -> " + loaded.item->output + ", " +
                       inputSize(loaded.environment);
    if (loaded.environment.replacedTexels > 0)
        line += ", " + counted(loaded.environment.replacedTexels, "NaN/Inf texel") + " replaced with 0";
    if (options.extractSun) line += loaded.sun ? ", sun taken out" : ", no sun found";
    printLine(batch, stdout, line);
}

// The backend, chosen once the first input is loaded (auto: from its work times the number of
// inputs), and the most texel bytes one chunk holds: a GPU submission's (--batch-bytes, at most
// the device's), or one input on the CPU.
struct BatchBackend {
    Backend backend;
    VkDeviceSize chunkBytes = 0;
};

BatchBackend chooseBatchBackend(Batch& batch, const Environment& first, size_t count) {
    const BakeOptions& options = batch.options;
    BatchBackend chosen{chooseBackend(options, projectionWork(options, first) * double(count)), 0};
    std::string device = cpuBackendName(chosen.backend.name);
    if (chosen.backend.session) {
        const Context& context = chosen.backend.session->context();
        device = context.info.name;
        chosen.chunkBytes = batchTexelBytes(context);
        if (options.batchBytes > 0)
            chosen.chunkBytes = std::min<VkDeviceSize>(chosen.chunkBytes, options.batchBytes);
    }
    printLine(batch, stdout, backendLine(chosen.backend, device));
    return chosen;
}

// Loads the inputs in order and bakes them in chunks of at most chunkBytes texel bytes (a larger
// input alone), one bake call each, writing each chunk's outputs before taking more: at most one
// chunk, the input that opens the next and the one loading after it are in memory.
void bakeInChunks(Batch& batch, const std::vector<BatchItem>& items) {
    std::optional<BatchBackend> chosen;
    std::vector<Loaded> chunk;
    VkDeviceSize bytes = 0;
    size_t said = 0; // the chunk's items written or reported so far
    // Bakes the chunk's loaded inputs, then writes them and reports its failures, in input order.
    auto flush = [&] {
        std::vector<const Environment*> environments;
        for (const Loaded& loaded : chunk)
            if (!loaded.failure) environments.push_back(&loaded.environment);
        std::vector<BakeResult> results;
        if (!environments.empty()) {
            results = bake(batch.options, chosen->backend, environments);
            // One submission per kind of map in the chunk on the GPU (bakeOnGpu).
            auto equirect = [](const Environment* environment) { return environment->keptEquirect(); };
            batch.submissions += size_t(std::any_of(environments.begin(), environments.end(), equirect)) +
                                 size_t(!std::all_of(environments.begin(), environments.end(), equirect));
        }
        size_t baked = 0;
        for (; said < chunk.size(); ++said) {
            const Loaded& loaded = chunk[said];
            if (loaded.failure)
                reportFailure(batch, *loaded.item, *loaded.failure);
            else
                writeItem(batch, chosen->backend, loaded, results[baked++]);
        }
        chunk.clear();
        said = 0;
        bytes = 0;
    };
    batch.progress.redraw();
    try {
        for (InputLoader loader(batch.options, items); !loader.done();) {
            Loaded loaded = loader.next();
            if (loaded.failure) {
                if (chunk.empty())
                    reportFailure(batch, *loaded.item, *loaded.failure);
                else
                    chunk.push_back(std::move(loaded)); // said after the inputs before it
                continue;
            }
            if (!chosen) chosen = chooseBatchBackend(batch, loaded.environment, items.size());
            fitBackend(chosen->backend, loaded.environment);
            VkDeviceSize itemBytes = environmentBytes(loaded.environment);
            if (!chunk.empty() && bytes + itemBytes > chosen->chunkBytes) flush();
            bytes += itemBytes;
            chunk.push_back(std::move(loaded));
        }
        flush();
    } catch (...) { // an error that ends the batch: the bad inputs waiting in the chunk are still said
        for (size_t i = said; i < chunk.size(); ++i)
            if (chunk[i].failure) reportFailure(batch, *chunk[i].item, *chunk[i].failure);
        throw;
    }
    batch.gpu = chosen && chosen->backend.session;
    if (batch.gpu) chosen->backend.session->finish();
}

std::string texelCount(uint64_t texels) {
    char text[32];
    if (texels >= 1000000)
        std::snprintf(text, sizeof(text), "%.1fM", double(texels) / 1e6);
    else
        std::snprintf(text, sizeof(text), "%llu", static_cast<unsigned long long>(texels));
    return text;
}

void printBatchStart(const BakeOptions& options, size_t count) {
    std::printf("shprobe bake: %zu inputs -> %s (order %d, %s)\n", count, options.outDir.c_str(),
                options.order, options.format.c_str());
    std::fflush(stdout);
}

// The summary line; then, if an input failed, the error that gives the exit code.
void finishBatch(Batch& batch, size_t count, double seconds) {
    batch.progress.disable();
    std::string submissions = batch.gpu
                                  ? " in " + std::to_string(batch.submissions) +
                                        (batch.submissions == 1 ? " GPU submission" : " GPU submissions")
                                  : std::string();
    std::printf("shprobe bake: %zu %s baked, %zu failed; %s texels%s; %.2f s, %.1f probes/s\n", batch.baked,
                batch.baked == 1 ? "probe" : "probes", batch.failed, texelCount(batch.texels).c_str(),
                submissions.c_str(), seconds, seconds > 0.0 ? double(batch.baked) / seconds : 0.0);
    std::fflush(stdout);
    if (batch.failed == 0) return;
    std::string written = batch.baked == 0   ? "nothing was written"
                          : batch.baked == 1 ? "the other probe was written to " + batch.options.outDir
                                             : "the other " + std::to_string(batch.baked) +
                                                   " probes were written to " + batch.options.outDir;
    throw Error(batch.inputFailed    ? ErrorKind::Input
                : batch.memoryFailed ? ErrorKind::Memory
                                     : ErrorKind::Output,
                std::to_string(batch.failed) + " of " + counted(count, "input") + " failed (above); " +
                    written);
}

} // namespace

void runBatchBake(const BakeOptions& options) {
    std::vector<BatchItem> items = planBatch(options);
    const bool created = prepareOutputFolder(options, items);

    Clock::time_point start = Clock::now();
    Batch batch{options,
                ProgressLine("probes", items.size(), options.quiet, ProgressLine::Style{.bar = true})};
    // A folder the batch made and wrote nothing into is not left behind (rmdir takes only an empty one).
    ScopeExit removeUnused([&] {
        if (created && batch.baked == 0) rmdir(options.outDir.c_str());
    });
    printBatchStart(options, items.size());
    bakeInChunks(batch, items);
    finishBatch(batch, items.size(), millisecondsSince(start) / 1000.0);
}

} // namespace shprobe
