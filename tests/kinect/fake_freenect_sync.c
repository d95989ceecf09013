/* A fake libfreenect_sync for the tests: the symbols robot_side/kinect/freenect.py uses, with the real
 * signatures (OpenKinect/libfreenect wrappers/c_sync/libfreenect_sync.h), serving synthetic 640x480 uint16
 * millimetre frames at FAKE_FREENECT_FPS (default 30) Hz:
 *   a wall at 2000 mm; a box at 1000 mm in columns 256..383 from row 160 down; columns 0..7 invalid (0).
 * Environment:
 *   FAKE_FREENECT_NO_DEVICE=1      every call fails as the real library does without a Kinect
 *   FAKE_FREENECT_UNPLUG_FILE=path when the file exists: "hang" in it -> the call blocks forever (a device
 *                                  that stops streaming); otherwise the file is removed and the call
 *                                  returns -1 once (an unplug; the next process finds the device again)
 * Build: cc -shared -fPIC -o libfake_freenect_sync.so fake_freenect_sync.c
 */
#include <errno.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#define W 640
#define H 480
#define FREENECT_RESOLUTION_MEDIUM 1
#define FREENECT_DEPTH_REGISTERED 4
#define FREENECT_DEPTH_MM 5

static uint16_t frame[W * H];
static uint32_t count;
static int streaming_fmt = -1;
static struct timespec next_due;

static void fill(void)
{
	for (int v = 0; v < H; ++v)
		for (int u = 0; u < W; ++u) {
			uint16_t mm = 2000;
			if (u >= 256 && u < 384 && v >= 160)
				mm = 1000;
			if (u < 8)
				mm = 0;
			frame[v * W + u] = mm;
		}
}

static void pace(void)
{
	const char *s = getenv("FAKE_FREENECT_FPS");
	double fps = s ? atof(s) : 30.0;
	long period = (long)(1e9 / (fps > 0 ? fps : 30.0));
	struct timespec now;
	clock_gettime(CLOCK_MONOTONIC, &now);
	if (next_due.tv_sec == 0)
		next_due = now;
	next_due.tv_nsec += period;
	while (next_due.tv_nsec >= 1000000000L) {
		next_due.tv_nsec -= 1000000000L;
		next_due.tv_sec += 1;
	}
	while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &next_due, NULL) == EINTR) {
	}
}

static int unplugged(void)
{
	const char *path = getenv("FAKE_FREENECT_UNPLUG_FILE");
	if (!path || access(path, F_OK) != 0)
		return 0;
	char buf[16] = {0};
	FILE *f = fopen(path, "r");
	if (f) {
		if (!fgets(buf, sizeof buf, f))
			buf[0] = 0;
		fclose(f);
	}
	if (strncmp(buf, "hang", 4) == 0) {
		fprintf(stderr, "fake freenect: device stopped streaming\n");
		for (;;)
			pause();
	}
	unlink(path);
	fprintf(stderr, "fake freenect: device unplugged\n");
	return 1;
}

int freenect_sync_get_depth_with_res(void **depth, uint32_t *timestamp, int index, int res, int fmt)
{
	if (getenv("FAKE_FREENECT_NO_DEVICE") || index != 0) {
		printf("Error: Invalid index [%d]\n", index);
		fflush(stdout);
		return -1;
	}
	if (res != FREENECT_RESOLUTION_MEDIUM || (fmt != FREENECT_DEPTH_MM && fmt != FREENECT_DEPTH_REGISTERED)) {
		printf("Invalid depth format %d\n", fmt);
		fflush(stdout);
		return -1;
	}
	if (unplugged())
		return -1;
	if (fmt != streaming_fmt) {
		fill();
		streaming_fmt = fmt;
		fprintf(stderr, "fake freenect: streaming device %d depth format %d\n", index, fmt);
	}
	pace();
	*timestamp = ++count;
	*depth = frame;
	return 0;
}

int freenect_sync_get_depth(void **depth, uint32_t *timestamp, int index, int fmt)
{
	return freenect_sync_get_depth_with_res(depth, timestamp, index, FREENECT_RESOLUTION_MEDIUM, fmt);
}

void freenect_sync_stop(void)
{
	streaming_fmt = -1;
	fprintf(stderr, "fake freenect: stopped after %u frames\n", count);
}
