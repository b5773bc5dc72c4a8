// Placeholder so the library has a translation unit; replaced by the surfacing stage (issue #5).
namespace cascade::surfacing { int placeholder = 0; }
