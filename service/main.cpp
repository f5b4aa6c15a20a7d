// facespace: blend-shape rigs from the command line, and the HTTP service.
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "commands/cli.h"

namespace {

const char kUsage[] =
    "usage: facespace COMMAND [ARGS]\n"
    "\n"
    "commands:\n"
    "  info RIG [SHAPE.obj ...] [--json]\n"
    "      shapes (names, groups, ranges, vertices moved), meshes, skeleton\n"
    "  blend RIG [SHAPE.obj ...] [--weights JSON | --weights @FILE | --set NAME=W ...]\n"
    "        [--mode relative|absolute] [--normals blend|recompute] [--keep-targets]\n"
    "        [--format glb|obj|json|f32|vrm|vrm0] -o OUT\n"
    "      the blended mesh; format from OUT's extension or --format; -o - writes to stdout\n"
    "  render RIG [weights flags] [--view shaded|wireframe|heatmap|normals|clay] [--width W "
    "--height H]\n"
    "        [--camera JSON | --yaw D --pitch D --zoom Z] [--background C] [--supersample N] -o "
    "OUT.png\n"
    "      an offscreen render (PNG, JPEG, EXR, TIFF; see render --help)\n"
    "  sheet RIG --cells JSON|@FILE [--columns N] [render flags] -o OUT.png\n"
    "      a labelled contact sheet of several weight vectors\n"
    "  sequence RIG (--keys JSON|@FILE | --from-animation CLIP | --obj-times T,...) [--transition "
    "T]\n"
    "        (--times JSON | --fps N | --reduce TOL | --bake T) [--format json|obj|glb|f32] -o "
    "OUT|DIR\n"
    "      keyframe sequences: in-betweens, baking, keyframe reduction\n"
    "  speak RIG (--text TEXT | --audio FILE.wav [--transcript T]) [--voice V] [--fps N] -o "
    "OUT.json|wav|webm|ndjson\n"
    "      lip sync: phonemes (espeak-ng or PocketSphinx) to visemes to keys; the audio; a video "
    "of the face speaking\n"
    "  fit RIG TARGET.(json|glb|obj) [--bounded] [--sum-at-most-one] [--align] -o FIT.json\n"
    "      the weights that best reproduce TARGET (least squares over the shapes)\n"
    "  batch RIG (--variants FILE.jsonl | --sample uniform|gaussian|grid|convex [--count N] "
    "[--seed S])\n"
    "        --out DIR [--format glb|obj|json|f32|vrm|png] [--jobs N] [--shard I/N|auto]\n"
    "      many variants as files with a manifest; resumable (batch --help for more)\n"
    "  batch merge DIR\n"
    "      one manifest and sheet from the shards of a batch run as a job array (Slurm, "
    "Kubernetes)\n"
    "  mirror RIG SHAPE [--as NAME] [--axis x|y|z] [--compress meshopt|none] -o OUT.glb\n"
    "      adds the left/right mirror image of a shape and writes the rig\n"
    "  compress RIG [--error E] [--bits 8..16] [--json]\n"
    "      orthogonal (PCA) basis of the shapes within an error bound, and quantised "
    "displacements: sizes and errors\n"
    "  convert RIG [--targets DIR --modifiers FILE [--groups G,...] [--metres] [--proxy "
    "FILE.mhclo]]\n"
    "          [--compress meshopt|none] -o OUT.glb\n"
    "      any rig (glTF, OBJ sequence, MakeHuman base.obj + .target folder) as a .glb with sparse "
    "targets + manifest\n"
    "  derive TARGET [--from SOURCE] -o OUT.glb [--landmarks FILE] [--shapes arkit,visemes]\n"
    "      SOURCE's shapes (default: the bundled FaceCap's ARKit 52) transferred onto TARGET's "
    "neutral\n"
    "  capture RIG FRAMES.json -o KEYS.json\n"
    "      a face tracker's landmarks over frames (MediaPipe's, the capture route's body) as RIG's "
    "weights\n"
    "  serve [--rigs DIR] [--host 127.0.0.1] [--port 8080] [--threads N] [--api-key-file FILE]\n"
    "        [--max-body BYTES] [--cors-origin ORIGIN ...]\n"
    "      the HTTP service (serve --help for more)\n"
    "\n"
    "RIG is any rig we read, told by its bytes: glTF 2.0 (.glb, .gltf), FBX, COLLADA (.dae), Doom "
    "3\n"
    "MD5 (.md5mesh), MikuMikuDance (.pmx, .pmd; .vmd motions beside it or in motion/), or a .obj "
    "file\n"
    "followed by more .obj files (an OBJ sequence: the first is the base, each other one a shape "
    "named\n"
    "after its file); with its manifest (NAME.manifest.json) when one is beside it.\n"
    "Every command takes -q / --quiet (no warnings) and --help (its flags, with their defaults);\n"
    "facespace --version says which this is.\n";

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fputs(kUsage, stderr);
    return 2;
  }
  const std::string command = argv[1];
  std::vector<std::string> args(argv + 2, argv + argc);
  if (command == "--version" || command == "version") {
    std::printf("facespace %s\n", FACESPACE_VERSION);
    return 0;
  }
  if (command == "-h" || command == "--help" || command == "help") {
    std::fputs(kUsage, stdout);
    return 0;
  }
  if (command == "--version") {
    std::puts("facespace 0.1.0");
    return 0;
  }
  if (command == "info") return facespace::cli::Info(args);
  if (command == "blend") return facespace::cli::Blend(args);
  if (command == "serve") return facespace::cli::Serve(args);
  if (command == "render") return facespace::cli::Render(args, false);
  if (command == "sheet") return facespace::cli::Render(args, true);
  if (command == "sequence") return facespace::cli::Sequence(args);
  if (command == "speak") return facespace::cli::Speak(args);
  if (command == "fit") return facespace::cli::FitCommand(args);
  if (command == "batch") return facespace::cli::Batch(args);
  if (command == "mirror") return facespace::cli::Mirror(args);
  if (command == "compress") return facespace::cli::Compress(args);
  if (command == "convert") return facespace::cli::Convert(args);
  if (command == "derive") return facespace::cli::Derive(args);
  if (command == "capture") return facespace::cli::Capture(args);
  std::fprintf(stderr, "facespace: unknown command '%s'\n\n%s", command.c_str(), kUsage);
  return 2;
}
