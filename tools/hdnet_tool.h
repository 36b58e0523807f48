/* hdnet_tool.h: the internal tool API. Everything the hdnet command (tools/) and its benchmarks use
 * beyond the public API of include/hdnet.h: the library's internal headers, gathered here so that
 * the line is drawn in one place. It lives beside the tool, not in include/: never installed, not
 * stable; a program outside this repository uses hdnet.h only, and what only the command does
 * (training, video clips, synthetic data, evaluation: docs/library.md, "What is public") is
 * reached through here. (Building against it needs -Isrc as well as -Iinclude.) */
#ifndef HDNET_TOOL_H
#define HDNET_TOOL_H

#include "hdnet.h"
#include "core/core.h"             /* errors, memory, atomic files, paths, time, threads */
#include "io/dataset.h"            /* SPEC section 5 folders */
#include "mesh/mesh.h"             /* the canonical mesh */
#include "nn/nn.h"                 /* layers, for the benchmarks */
#include "model/unet.h"            /* Common-Net, for the benchmarks */
#include "model/hdnet_net.h"       /* HD-Net, for the benchmarks and `hdnet info` */
#include "model/checkpoint.h"      /* the checkpoint format, for `hdnet init` */
#include "train/train.h"           /* training: `hdnet train` */
#include "synth/synth.h"           /* synthetic faces: `hdnet synth` */
#include "eval/eval.h"             /* the metrics, photo and pair evaluations: `hdnet eval` */
#include "align/face_detect.h"     /* the detector, for `hdnet detect` */
#include "align/face_landmarks.h"  /* the face mesh, for `hdnet detect` */
#include "apply/apply.h"           /* the relighting rule's pieces, for `hdnet eval --sheets` */
#include "eval/multilight.h"        /* `hdnet eval --multilight` */
#include "video/video.h"           /* video clips, for relight, transfer and delight of a clip */

#endif /* HDNET_TOOL_H */
