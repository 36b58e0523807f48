/* test_header_example.c: compiles and runs the usage example in the opening comment of
 * include/hdnet.h (the Makefile extracts it into header_example.inc), so the example cannot rot. */
#include <stdio.h>
#include <string.h>
#include "hdnet.h"
#include "test.h"

#include "header_example.inc"
#include "io/image_io.h"

int main(void)
{
    CHECK(example("example-sphere.png") == 0);
    hd_image img = {0};
    CHECK(hd_image_read("example-sphere.png", &img) == HD_OK);
    CHECK(img.width == 128 && img.height == 128 && img.channels == 3);
    hd_image_free(&img);
    CHECK(example("no/such/dir/sphere.png") == 1);
    CHECK(strstr(hd_error(), "no/such/dir") != NULL);
    return test_summary("header_example");
}
