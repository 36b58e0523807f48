/* tfjs_graph.h: a small runner for TensorFlow.js graph models (model.json + weight shards), enough
 * for MediaPipe's face detector, face mesh and selfie segmentation: the JSON GraphDef is read with cJSON, the weights
 * are checked against the manifest and the shard sizes before any byte is read, shapes are inferred
 * once at load, and a run executes the nodes in topological order over NHWC float32 tensors placed
 * in one arena (buffers whose lives do not overlap share memory).
 *
 * Supported ops: Placeholder, Const, Identity, _FusedConv2D (fused_ops BiasAdd then optionally
 * Relu, Relu6, Prelu or LeakyRelu), Conv2D, DepthwiseConv2dNative, FusedDepthwiseConv2dNative,
 * Add/AddV2/Sub/Mul (numpy broadcasting), Relu, Relu6, Prelu, Sigmoid, Tanh, Pad/PadV2 (constant),
 * MaxPool, AvgPool, Reshape, AddN, ResizeBilinear (its three sampling grids), Conv2DBackpropInput
 * (a transposed convolution, no dilation). Padding SAME, VALID or EXPLICIT; data_format NHWC only; batch 1.
 * Weight dtypes float32 and int32, with the TF.js quantizations float16, uint8 and uint16.
 * Anything else is refused at load with an error naming the node. */
#ifndef HD_TFJS_GRAPH_H
#define HD_TFJS_GRAPH_H

#include <stdint.h>
#include "hdnet.h"

#define HD_TFJS_MAX_DIMS 4

typedef struct hd_tfjs_graph hd_tfjs_graph;

/* Loads a graph model: json_path and the shards its weightsManifest names (relative to the
 * JSON's folder). Every node's op, attributes, inputs and shapes are checked here, so that a run
 * cannot fail on a malformed model. */
hd_status hd_tfjs_load(const char *json_path, hd_tfjs_graph **graph);
void hd_tfjs_free(hd_tfjs_graph *graph);

/* The shape of the graph's single Placeholder (NHWC, batch 1). */
void hd_tfjs_input_shape(const hd_tfjs_graph *graph, int *height, int *width, int *channels);

/* Runs the graph on input (1, H, W, C) of the Placeholder's shape. Fails only when a value turns
 * into NaN or infinity (named by node). */
hd_status hd_tfjs_run(hd_tfjs_graph *graph, const float *input);

/* The output node called `name` (a ":0" suffix is accepted): a node no
 * other node reads, or an Identity/Reshape of one (intermediate buffers are reused during the run).
 * Row-major, with its shape (ndim <= HD_TFJS_MAX_DIMS, dims may be NULL); the shape is known from
 * the load, the values from the last run (until the next run or free). NULL with an
 * HD_ERR_NOTFOUND reason when there is no such output. */
const float *hd_tfjs_output(const hd_tfjs_graph *graph, const char *name, int *ndim, int dims[HD_TFJS_MAX_DIMS]);

/* IEEE 754 binary16 to float (exact, subnormals, infinities and NaN included). */
float hd_half_to_float(uint16_t h);

#endif /* HD_TFJS_GRAPH_H */
