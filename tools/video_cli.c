/* video_cli.c: relight, delight and transfer on a clip (video_cli.h): loads the model and the
 * aligner once, runs the clip through src/video's frame loop, prints what was written. */
#include <stdio.h>
#include <sys/stat.h>
#include "cli.h"
#include "hdnet_tool.h"
#include "video_cli.h"

int cli_is_clip(const char *input, const cli_clip *clip)
{
    struct stat sb;
    if (clip->fps != 0.0f && stat(input, &sb) == 0 && S_ISDIR(sb.st_mode)) return 1; /* a bad --fps is reported */
    return hd_path_is_video(input);
}

int cli_video(const char *cmd, const char *in, const char *out, const char *model_path, const float *light,
                 const char *ref, hd_brightness brightness, const cli_clip *clip)
{
    if (!(clip->fps >= 0.0f && clip->fps <= 1000.0f)) {
        fprintf(stderr, "hdnet %s: usage error: --fps must be in (0, 1000], got %g\n", cmd, (double)clip->fps);
        return CLI_EXIT_USAGE;
    }
    if ((hd_path_is_video(in) || hd_path_is_video(out)) && !hd_video_supported()) {
        fprintf(stderr, "hdnet %s: %s\n", cmd, HD_VIDEO_HOW_TO);
        return CLI_EXIT_FAIL;
    }
    hd_model *model = NULL;
    hd_aligner *aligner = NULL;
    hd_video_relighter *v = NULL;
    hd_image ref_image = {0};
    float ref_light[HD_SH_COEFFS];
    int rc = CLI_EXIT_FAIL, nfaces = 0;
    hd_video_options opt;
    hd_video_options_default(&opt);
    opt.smooth = !clip->no_smooth;
    if (hd_model_load(model_path, &model) != HD_OK || hd_aligner_load(&aligner) != HD_OK ||
        hd_model_set_background(model, clip->background) != HD_OK || hd_model_set_shadows(model, clip->shadows) != HD_OK) {
        rc = cli_report(cmd);
        goto done;
    }
    if (ref) {
        int ref_photo = hd_input_kind_of(ref) == HD_INPUT_PHOTO;
        hd_status st = hd_image_read_as(ref, 3, &ref_image);
        if (st == HD_OK)
            st = ref_photo ? hd_estimate_light_photo(model, aligner, &ref_image, ref_light, &nfaces)
                           : hd_estimate_light(model, &ref_image, ref_light);
        if (st != HD_OK) {
            rc = ref_photo ? cli_report_photo(cmd, st, ref) : cli_report(cmd);
            goto done;
        }
        light = ref_light;
    }
    hd_video_report report;
    if (hd_video_relighter_new(model, aligner, light, brightness, &opt, &v) != HD_OK ||
        hd_video_relight_clip(v, in, out, clip->fps, &report) != HD_OK) {
        rc = cli_report(cmd);
        goto done;
    }
    char held[64] = "";
    if (report.frames_wall_held > 0) snprintf(held, sizeof held, ", %ld with the wall held", report.frames_wall_held);
    printf("%s -> %s: %ld frames (%ld with a face%s), light change %.4f per frame%s, %.1f s (%.2f frames/s)\n", in,
           out, report.frames, report.frames_with_face, held, report.light_change, opt.smooth ? " (smoothed)" : "",
           report.seconds, report.seconds > 0 ? (double)report.frames / report.seconds : 0.0);
    rc = CLI_EXIT_OK;
done:
    hd_video_relighter_free(v);
    hd_image_free(&ref_image);
    if (model) hd_model_free(model);
    hd_aligner_free(aligner);
    return rc;
}
