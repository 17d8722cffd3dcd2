#pragma once
// Subcommand entry points of mapdelta-client; argv[0] is the subcommand name.
namespace mapdelta::client::app {

int RunDisparity(int argc, char** argv);
int RunConfig(int argc, char** argv);
int RunPipelineCommand(int argc, char** argv);  // "run": the library's RunPipeline over a sequence
int RunUpload(int argc, char** argv);
int RunDrift(int argc, char** argv);
int RunDepthEval(int argc, char** argv);

}  // namespace mapdelta::client::app
