// ivoct export/ — the VTK side: .vtu (surface leaves as voxels), .vtp meshes,
// and reading them back (.htg and .phtg too) for `ivoct info`.  The .htg
// itself is written by htg_xml.cpp, without VTK's writer.
//
// VTK writers are asked for a string (WriteToOutputString) which goes to the
// file through io/io.h: one path for temporary names, devices and errors.
#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstring>
#include <fstream>
#include <map>
#include <memory>

#include <vtkCellArray.h>
#include <vtkCellData.h>
#include <vtkCellType.h>
#include <vtkCommand.h>
#include <vtkDoubleArray.h>
#include <vtkFieldData.h>
#include <vtkFloatArray.h>
#include <vtkHyperTree.h>
#include <vtkHyperTreeGrid.h>
#include <vtkIdTypeArray.h>
#include <vtkIntArray.h>
#include <vtkLogger.h>
#include <vtkNew.h>
#include <vtkObjectFactory.h>
#include <vtkOutputWindow.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>
#include <vtkSignedCharArray.h>
#include <vtkSmartPointer.h>
#include <vtkStringArray.h>
#include <vtkUnsignedCharArray.h>
#include <vtkUnstructuredGrid.h>
#include <vtkXMLHyperTreeGridReader.h>
#include <vtkXMLPHyperTreeGridReader.h>
#include <vtkXMLPUnstructuredGridReader.h>
#include <vtkXMLPolyDataReader.h>
#include <vtkXMLPolyDataWriter.h>
#include <vtkXMLUnstructuredGridReader.h>
#include <vtkXMLUnstructuredGridWriter.h>

#include "internal.hpp"

namespace ivexp {
namespace {

// ---- errors ---------------------------------------------------------------------------
// VTK prints its errors (vtkOutputWindow, and vtkLogger on stderr) unless the
// object that has one has an ErrorEvent observer.  While ivoct's code runs,
// the object watched has an observer, and every other object's text goes to
// a window of ours; the first error of either is the message.

// "ERROR: In FILE, line N\nCLASS (0x...): text\n\n" -> "text", on one line
std::string vtk_message(const char *text)
{
    std::string m = text ? text : "";
    size_t p = m.find("): ");
    if (p != std::string::npos)
        m = m.substr(p + 3);
    while (!m.empty() && std::isspace((unsigned char)m.back()))
        m.pop_back();
    for (char &c : m)
        if (c == '\n')
            c = ' ';
    return m;
}

class Catcher : public vtkCommand {
public:
    static Catcher *New() { return new Catcher; }
    void Execute(vtkObject *, unsigned long event, void *data) override
    {
        if (event != vtkCommand::ErrorEvent || !message.empty())
            return;
        // readers signal a failed read with an event and no text
        message = data ? vtk_message(static_cast<const char *>(data)) : "truncated or corrupt";
    }
    std::string message;
};

class Window : public vtkOutputWindow {
public:
    static Window *New();
    vtkTypeMacro(Window, vtkOutputWindow)
    void DisplayText(const char *) override {}
    void DisplayErrorText(const char *text) override
    {
        if (message.empty())
            message = vtk_message(text);
    }
    void DisplayWarningText(const char *) override {}
    void DisplayGenericWarningText(const char *) override {}
    void DisplayDebugText(const char *) override {}
    std::string message;
};
vtkStandardNewMacro(Window);

class Quiet {
public:
    explicit Quiet(vtkObject *watched) : watched_(watched), previous_(vtkOutputWindow::GetInstance())
    {
        // VTK's logger would print errors on stderr before any window sees them;
        // nothing else in ivoct logs through it
        vtkLogger::SetStderrVerbosity(vtkLogger::VERBOSITY_OFF);
        if (previous_)
            previous_->Register(nullptr);
        vtkOutputWindow::SetInstance(window_);
        tag_ = watched_->AddObserver(vtkCommand::ErrorEvent, catcher_);
        tag2_ = watched_->AddObserver(vtkCommand::WarningEvent, catcher_);
    }
    ~Quiet()
    {
        watched_->RemoveObserver(tag_);
        watched_->RemoveObserver(tag2_);
        vtkOutputWindow::SetInstance(previous_);
        if (previous_)
            previous_->UnRegister(nullptr);
    }
    Quiet(const Quiet &) = delete;
    Quiet &operator=(const Quiet &) = delete;
    std::string message() const
    {
        return !catcher_->message.empty() ? catcher_->message : window_->message;
    }

private:
    vtkObject *watched_;
    vtkOutputWindow *previous_;
    vtkNew<Catcher> catcher_;
    vtkNew<Window> window_;
    unsigned long tag_, tag2_;
};

// ---- helpers --------------------------------------------------------------------------
enum { CLASS_SURFACE = 3 };  // the .htg's class of a surface leaf (htg_xml.cpp)

void add_field_data(vtkFieldData *fd, const oct_tree_t *tree, const oct_source_t *src)
{
    for (const MetaItem &m : meta_strings(src)) {
        vtkNew<vtkStringArray> a;
        a->SetName(m.key.c_str());
        a->InsertNextValue(m.value);
        fd->AddArray(a);
    }
    vtkNew<vtkDoubleArray> box;
    box->SetName("box");
    box->SetNumberOfValues(6);
    for (int i = 0; i < 6; i++)
        box->SetValue(i, tree->box[i]);
    fd->AddArray(box);
    vtkNew<vtkIntArray> depth;
    depth->SetName("depth");
    depth->InsertNextValue(tree->depth);
    fd->AddArray(depth);
}

// The writer's output string itself (a protected member; GetOutputString
// returns a copy of what may be hundreds of MB).
struct OutputStringOf : vtkXMLWriterBase {
    static std::string &of(vtkXMLWriterBase *w) { return w->*(&OutputStringOf::OutputString); }
};

template <class Writer> void write_xml(Writer *w, vtkDataObject *data, const char *path)
{
    Quiet q(w);
    w->SetInputData(data);
    w->SetWriteToOutputString(true);
    w->SetHeaderTypeToUInt64();
    // LZ4: at depth 9 about twice the size of zlib's output in half the time or
    // less (zlib's deflate was most of the writers' time); VTK >= 8.2 reads it
    w->SetCompressorTypeToLZ4();
    if (!w->Write()) {
        std::string m = q.message();
        throw Error(std::string("cannot write ") + path + ": " + (m.empty() ? "VTK writer failed" : m));
    }
    Output out(path);
    std::string &s = OutputStringOf::of(w);
    out.write(s.data(), s.size());
    std::string().swap(s);
    out.commit();
}

struct Corner {
    uint32_t x, y, z;
    bool operator<(const Corner &o) const
    {
        return z != o.z ? z < o.z : y != o.y ? y < o.y : x < o.x;
    }
    bool operator==(const Corner &o) const { return x == o.x && y == o.y && z == o.z; }
};


// Corner c of leaf i (VTK_VOXEL order: x fastest, then y, then z), in integer
// coordinates of the max depth D.
inline Corner leaf_corner(const oct_tree_t *tree, size_t i, int c)
{
    const oct_leaf_t &l = tree->leaves[i];
    uint32_t ix, iy, iz;
    int depth = oct_leaf_depth(&l);
    oct_unmorton(oct_leaf_code(&l), depth, &ix, &iy, &iz);
    uint32_t s = 1u << (tree->depth - depth);
    return {(ix + (c & 1)) * s, (iy + (c >> 1 & 1)) * s, (iz + (c >> 2 & 1)) * s};
}

// The points of the .vtu: the distinct leaf corners in (z, y, x) order, written
// into `points`, and for corner c of leaf i its index in them in conn[8 i + c].
//
// Up to depth 15 the corners are bucketed by z (one pass over the leaves), and
// each z slice is sorted on its own by a radix sort of 64-bit words (y, x) << 32
// | corner number: a slice fits in cache, and slices are independent, so they
// go over the threads.  Deeper (or more than 2^32 corners), a comparison sort.
void shared_points(const oct_tree_t *tree, vtkIdType *conn, vtkPoints *points)
{
    const size_t n = tree->n_leaves, m = 8 * n;
    const int D = tree->depth, bits = D + 1;
    auto coord = [tree, D](int axis, uint64_t i) {
        return oct_coord(tree->box[2 * axis], tree->box[2 * axis + 1], i, D);
    };
    if (2 * bits + 32 > 64 || m > UINT32_MAX) {
        std::vector<Corner> corners(m);
        for (size_t i = 0; i < n; i++)
            for (int c = 0; c < 8; c++)
                corners[8 * i + c] = leaf_corner(tree, i, c);
        std::vector<Corner> unique = corners;
        std::sort(unique.begin(), unique.end());
        unique.erase(std::unique(unique.begin(), unique.end()), unique.end());
        for (size_t k = 0; k < m; k++)
            conn[k] = (vtkIdType)(std::lower_bound(unique.begin(), unique.end(), corners[k]) -
                                  unique.begin());
        points->SetNumberOfPoints((vtkIdType)unique.size());
        double *xyz = static_cast<double *>(points->GetVoidPointer(0));
        for (size_t p = 0; p < unique.size(); p++) {
            xyz[3 * p] = coord(0, unique[p].x);
            xyz[3 * p + 1] = coord(1, unique[p].y);
            xyz[3 * p + 2] = coord(2, unique[p].z);
        }
        return;
    }
    // leaf i's lowest corner and its size, in integer coordinates of depth D
    auto anchor = [tree, D](size_t i, uint32_t a[3], uint32_t &size) {
        const oct_leaf_t &l = tree->leaves[i];
        const int depth = oct_leaf_depth(&l);
        oct_unmorton(oct_leaf_code(&l), depth, &a[0], &a[1], &a[2]);
        size = 1u << (D - depth);
        for (int k = 0; k < 3; k++)
            a[k] *= size;
    };
    const size_t n_slices = ((size_t)1 << D) + 1;
    // the slices' extents in `entries` (a counting sort by z)
    std::vector<size_t> start(n_slices + 1, 0);
    for (size_t i = 0; i < n; i++) {
        uint32_t a[3], s;
        anchor(i, a, s);
        start[(size_t)a[2] + 1] += 4;
        start[(size_t)a[2] + s + 1] += 4;
    }
    for (size_t z = 0; z < n_slices; z++)
        start[z + 1] += start[z];
    std::unique_ptr<uint64_t[]> entries(new uint64_t[m]);
    {
        std::vector<size_t> fill(start.begin(), start.end() - 1);
        for (size_t i = 0; i < n; i++) {
            uint32_t a[3], s;
            anchor(i, a, s);
            for (uint32_t c = 0; c < 8; c++) {
                const uint64_t x = a[0] + (c & 1) * s, y = a[1] + (c >> 1 & 1) * s;
                const size_t z = (size_t)a[2] + (c >> 2 & 1) * s;
                entries[fill[z]++] = (y << bits | x) << 32 | (uint64_t)(8 * i + c);
            }
        }
    }
    const int threads = writer_threads(tree, n_slices);
    const size_t chunk = (n_slices + 64 * (size_t)threads - 1) / (64 * (size_t)threads);
    // sort every slice, count its distinct corners
    std::vector<size_t> first_point(n_slices + 1, 0);
    parallel_chunks(n_slices, chunk, threads, [&](size_t z0, size_t z1, int) {
        const int digit = 11;
        std::vector<uint64_t> tmp;
        std::vector<uint32_t> count((size_t)1 << digit);
        for (size_t z = z0; z < z1; z++) {
            uint64_t *e = entries.get() + start[z];
            const size_t k = start[z + 1] - start[z];
            if (k == 0)
                continue;
            tmp.resize(k);
            uint64_t *from = e, *to = tmp.data();
            for (int shift = 32; shift < 32 + 2 * bits; shift += digit) {  // LSD: stable
                std::fill(count.begin(), count.end(), 0);
                const uint64_t mask = ((uint64_t)1 << digit) - 1;
                for (size_t j = 0; j < k; j++)
                    count[(from[j] >> shift) & mask]++;
                uint32_t sum = 0;
                for (uint32_t &c : count) {
                    const uint32_t v = c;
                    c = sum;
                    sum += v;
                }
                for (size_t j = 0; j < k; j++)
                    to[count[(from[j] >> shift) & mask]++] = from[j];
                std::swap(from, to);
            }
            if (from != e)
                std::copy(from, from + k, e);
            size_t distinct = 1;
            for (size_t j = 1; j < k; j++)
                distinct += (e[j] >> 32) != (e[j - 1] >> 32);
            first_point[z + 1] = distinct;
        }
    });
    for (size_t z = 0; z < n_slices; z++)
        first_point[z + 1] += first_point[z];
    points->SetNumberOfPoints((vtkIdType)first_point[n_slices]);
    double *xyz = static_cast<double *>(points->GetVoidPointer(0));
    // number the points, slice by slice from its first
    const uint64_t lmask = ((uint64_t)1 << bits) - 1;
    parallel_chunks(n_slices, chunk, threads, [&](size_t z0, size_t z1, int) {
        for (size_t z = z0; z < z1; z++) {
            const uint64_t *e = entries.get() + start[z];
            const size_t k = start[z + 1] - start[z];
            const double zc = coord(2, z);
            size_t p = first_point[z] - 1;
            for (size_t j = 0; j < k; j++) {
                const uint64_t key = e[j] >> 32;
                if (j == 0 || key != e[j - 1] >> 32) {
                    p++;
                    xyz[3 * p] = coord(0, key & lmask);
                    xyz[3 * p + 1] = coord(1, key >> bits);
                    xyz[3 * p + 2] = zc;
                }
                conn[(uint32_t)e[j]] = (vtkIdType)p;
            }
        }
    });
}

}  // namespace

// ---- .vtu -----------------------------------------------------------------------------
void vtk_write_vtu(const oct_tree_t *tree, const oct_source_t *src, const char *path)
{
    const size_t n = tree->n_leaves;
    // corners in integer coordinates of the max depth, shared between neighbours:
    // the points are the distinct corners in (z, y, x) order
    vtkNew<vtkPoints> points;
    points->SetDataTypeToDouble();
    vtkNew<vtkIdTypeArray> offsets, connectivity;
    offsets->SetNumberOfValues((vtkIdType)n + 1);
    connectivity->SetNumberOfValues((vtkIdType)(8 * n));
    for (size_t i = 0; i <= n; i++)
        offsets->SetValue((vtkIdType)i, (vtkIdType)(8 * i));
    shared_points(tree, connectivity->GetPointer(0), points);
    vtkNew<vtkCellArray> cells;
    cells->SetData(offsets, connectivity);
    vtkNew<vtkUnsignedCharArray> types;
    types->SetNumberOfValues((vtkIdType)n);
    types->FillValue(VTK_VOXEL);

    vtkNew<vtkUnstructuredGrid> ug;
    ug->SetPoints(points);
    ug->SetCells(types, cells);

    vtkNew<vtkIntArray> depth;
    vtkNew<vtkDoubleArray> f_lo, f_hi, error_bound;
    depth->SetName("depth");
    f_lo->SetName("f_lo");
    f_hi->SetName("f_hi");
    error_bound->SetName("error_bound");
    for (vtkDataArray *a : {(vtkDataArray *)depth, (vtkDataArray *)f_lo, (vtkDataArray *)f_hi,
                            (vtkDataArray *)error_bound})
        a->SetNumberOfTuples((vtkIdType)n);
    {
        int *depth_v = depth->GetPointer(0);
        double *lo = f_lo->GetPointer(0), *hi = f_hi->GetPointer(0);
        double *eb = error_bound->GetPointer(0);
        const size_t chunk = 65536;
        parallel_chunks(n, chunk, writer_threads(tree, (n + chunk - 1) / chunk),
                        [&](size_t s, size_t e, int) {
                            for (size_t i = s; i < e; i++) {
                                const oct_leaf_t &l = tree->leaves[i];
                                depth_v[i] = oct_leaf_depth(&l);
                                lo[i] = l.f_lo;
                                hi[i] = l.f_hi;
                                eb[i] = oct_leaf_error_bound(tree, (uint32_t)i);
                            }
                        });
    }
    vtkCellData *cd = ug->GetCellData();
    cd->AddArray(depth);
    cd->AddArray(f_lo);
    cd->AddArray(f_hi);
    cd->AddArray(error_bound);
    if (tree->certain) {
        // 1 where the leaf surely holds surface (oct_certify)
        vtkNew<vtkUnsignedCharArray> certain;
        certain->SetName("certain");
        certain->SetNumberOfTuples((vtkIdType)n);
        unsigned char *c = certain->GetPointer(0);
        for (size_t i = 0; i < n; i++)
            c[i] = tree->certain[i] != 0;
        cd->AddArray(certain);
    }
    if (tree->slabs) {
        vtkNew<vtkDoubleArray> normal;
        normal->SetName("normal");
        normal->SetNumberOfComponents(3);
        normal->SetNumberOfTuples((vtkIdType)n);
        for (uint32_t i = 0; i < n; i++)
            normal->SetTuple(i, tree->slabs[i].n);
        cd->AddArray(normal);
    }
    cd->SetActiveScalars("depth");
    add_field_data(ug->GetFieldData(), tree, src);

    vtkNew<vtkXMLUnstructuredGridWriter> w;
    w->SetDataModeToAppended();
    w->EncodeAppendedDataOff();
    write_xml(w.Get(), ug, path);
}

// ---- .htg: htg_xml.cpp (VTK's HyperTreeGrid XML format, written without VTK's writer) ----

// ---- .vtp -----------------------------------------------------------------------------
void vtk_write_vtp(const Mesh &mesh, const oct_source_t *src, const char *path)
{
    const vtkIdType np = (vtkIdType)(mesh.points.size() / 3), nt = (vtkIdType)(mesh.tris.size() / 3);
    vtkSmartPointer<vtkDataArray> coords;
    if (mesh.doubles) {
        auto d = vtkSmartPointer<vtkDoubleArray>::New();
        d->SetNumberOfComponents(3);
        d->SetNumberOfTuples(np);
        std::copy(mesh.points.begin(), mesh.points.end(), d->GetPointer(0));
        coords = d;
    } else {
        auto f = vtkSmartPointer<vtkFloatArray>::New();
        f->SetNumberOfComponents(3);
        f->SetNumberOfTuples(np);
        std::transform(mesh.points.begin(), mesh.points.end(), f->GetPointer(0),
                       [](double x) { return (float)x; });
        coords = f;
    }
    vtkNew<vtkPoints> points;
    points->SetData(coords);
    vtkNew<vtkIdTypeArray> offsets, connectivity;
    offsets->SetNumberOfValues(nt + 1);
    connectivity->SetNumberOfValues(3 * nt);
    for (vtkIdType t = 0; t <= nt; t++)
        offsets->SetValue(t, 3 * t);
    for (vtkIdType k = 0; k < 3 * nt; k++)
        connectivity->SetValue(k, (vtkIdType)mesh.tris[(size_t)k]);
    vtkNew<vtkCellArray> polys;
    polys->SetData(offsets, connectivity);
    vtkNew<vtkPolyData> pd;
    pd->SetPoints(points);
    pd->SetPolys(polys);
    if (!mesh.tri_depth.empty()) {
        vtkNew<vtkIntArray> depth;
        depth->SetName("depth");
        depth->SetNumberOfValues(nt);
        std::copy(mesh.tri_depth.begin(), mesh.tri_depth.end(), depth->GetPointer(0));
        pd->GetCellData()->AddArray(depth);
    }
    for (const MetaItem &m : meta_strings(src)) {
        vtkNew<vtkStringArray> a;
        a->SetName(m.key.c_str());
        a->InsertNextValue(m.value);
        pd->GetFieldData()->AddArray(a);
    }
    vtkNew<vtkXMLPolyDataWriter> w;
    w->SetDataModeToAppended();
    w->EncodeAppendedDataOff();
    write_xml(w.Get(), pd, path);
}

// ---- info -----------------------------------------------------------------------------
namespace {

std::string xml_type(const char *path)
{
    std::ifstream in(path, std::ios::binary);
    std::string head(1024, '\0');
    in.read(&head[0], (std::streamsize)head.size());
    head.resize((size_t)in.gcount());
    size_t p = head.find("<VTKFile");
    if (p == std::string::npos)
        return "";
    size_t t = head.find("type=\"", p);
    if (t == std::string::npos)
        return "";
    t += 6;
    size_t e = head.find('"', t);
    return e == std::string::npos ? "" : head.substr(t, e - t);
}

template <class Reader> void read_xml(Reader *r, const char *path)
{
    Quiet q(r);
    r->SetFileName(path);
    r->Update();
    std::string m = q.message();
    if (!m.empty() || !r->GetOutput())
        throw Error(std::string("cannot read ") + path + ": " +
                    (m.empty() ? "not a valid VTK file" : m));
}

void print_field_data(FILE *out, vtkFieldData *fd)
{
    if (!fd)
        return;
    auto text = [&](const char *key) -> const char * {
        auto *a = vtkStringArray::SafeDownCast(fd->GetAbstractArray(key));
        return a && a->GetNumberOfValues() > 0 ? a->GetValue(0).c_str() : nullptr;
    };
    if (const char *s = text("scene"))
        std::fprintf(out, "scene:    %s\n", s);
    for (int i = 0; i < fd->GetNumberOfArrays(); i++) {
        const char *name = fd->GetAbstractArray(i)->GetName();
        const char *value = name && !std::strncmp(name, "let.", 4) ? text(name) : nullptr;
        if (value)
            std::fprintf(out, "let:      %s = %s\n", name + 4, value);
    }
    if (const char *s = text("expression"))
        std::fprintf(out, "f:        %s\n", s);
    auto *box = vtkDoubleArray::SafeDownCast(fd->GetArray("box"));
    if (box && box->GetNumberOfValues() == 6)
        std::fprintf(out, "box:      [%.17g, %.17g] x [%.17g, %.17g] x [%.17g, %.17g]\n",
                     box->GetValue(0), box->GetValue(1), box->GetValue(2), box->GetValue(3),
                     box->GetValue(4), box->GetValue(5));
    auto *depth = vtkIntArray::SafeDownCast(fd->GetArray("depth"));
    if (depth && depth->GetNumberOfValues() == 1)
        std::fprintf(out, "depth:    %d\n", depth->GetValue(0));
}

void print_arrays(FILE *out, vtkFieldData *cd)
{
    std::fprintf(out, "arrays:  ");
    for (int i = 0; i < cd->GetNumberOfArrays(); i++) {
        vtkAbstractArray *a = cd->GetAbstractArray(i);
        std::fprintf(out, " %s", a->GetName() ? a->GetName() : "?");
        if (a->GetNumberOfComponents() > 1)
            std::fprintf(out, "[%d]", a->GetNumberOfComponents());
    }
    std::fprintf(out, "\n");
}

// "leaves by depth: d:n ..." from a depth array over the cells where keep(i)
template <class Keep>
void print_by_depth(FILE *out, const char *label, vtkDataArray *depth, Keep keep)
{
    if (!depth)
        return;
    std::map<long, unsigned long long> count;
    for (vtkIdType i = 0; i < depth->GetNumberOfTuples(); i++)
        if (keep(i))
            count[(long)depth->GetTuple1(i)]++;
    std::fprintf(out, "%s:", label);
    for (auto &c : count)
        std::fprintf(out, " %ld:%llu", c.first, c.second);
    if (count.empty())
        std::fprintf(out, " none");
    std::fprintf(out, "\n");
}

double max_of(vtkDataArray *a)
{
    double m = -INFINITY;
    for (vtkIdType i = 0; a && i < a->GetNumberOfTuples(); i++)
        m = std::max(m, a->GetTuple1(i));
    return m;
}

// The summaries of `ivoct info`: a .vtu (or the pieces of a .pvtu put together).
void ug_info(FILE *out, const char *path, const char *what, vtkUnstructuredGrid *ug)
{
    vtkCellData *cd = ug->GetCellData();
    std::fprintf(out, "file:     %s (%s)\n", path, what);
    print_field_data(out, ug->GetFieldData());
    std::fprintf(out, "leaves:   %lld\n", (long long)ug->GetNumberOfCells());
    std::fprintf(out, "points:   %lld\n", (long long)ug->GetNumberOfPoints());
    print_by_depth(out, "leaves by depth", cd->GetArray("depth"), [](vtkIdType) { return true; });
    vtkDataArray *e = cd->GetArray("error_bound");
    if (e && e->GetNumberOfTuples() > 0)
        std::fprintf(out, "max error bound: %.17g\n", max_of(e));
    print_arrays(out, cd);
}

// A .htg (or the pieces of a .phtg put together).
void htg_info(FILE *out, const char *path, const char *what, vtkHyperTreeGrid *h)
{
    vtkCellData *cd = h->GetCellData();
    std::fprintf(out, "file:     %s (%s)\n", path, what);
    print_field_data(out, h->GetFieldData());
    // VTK 9.1's reader drops the field data: box and depth from the grid itself
    if (!h->GetFieldData() || !h->GetFieldData()->GetArray("box")) {
        vtkDataArray *c[3] = {h->GetXCoordinates(), h->GetYCoordinates(), h->GetZCoordinates()};
        if (c[0] && c[1] && c[2] && c[0]->GetNumberOfTuples() > 0 &&
            c[1]->GetNumberOfTuples() > 0 && c[2]->GetNumberOfTuples() > 0) {
            std::fprintf(out, "box:     ");
            for (int a = 0; a < 3; a++)
                std::fprintf(out, "%s[%.17g, %.17g]", a ? " x " : " ", c[a]->GetTuple1(0),
                             c[a]->GetTuple1(c[a]->GetNumberOfTuples() - 1));
            std::fprintf(out, "\n");
        }
        if (vtkDataArray *d = cd->GetArray("depth"))
            if (d->GetNumberOfTuples() > 0)
                std::fprintf(out, "depth:    %.0f\n", max_of(d));
    }
    unsigned dims[3];
    h->GetCellDims(dims);
    std::fprintf(out, "trees:    %u x %u x %u\n", dims[0], dims[1], dims[2]);
    std::fprintf(out, "nodes:    %lld\n", (long long)h->GetNumberOfVertices());
    std::fprintf(out, "leaves (all): %lld\n", (long long)h->GetNumberOfLeaves());
    vtkDataArray *cls = cd->GetArray("class");
    if (cls) {
        unsigned long long n = 0;
        for (vtkIdType i = 0; i < cls->GetNumberOfTuples(); i++)
            n += cls->GetTuple1(i) == CLASS_SURFACE;
        std::fprintf(out, "leaves:   %llu\n", n);
        print_by_depth(out, "leaves by depth", cd->GetArray("depth"),
                       [&](vtkIdType i) { return cls->GetTuple1(i) == CLASS_SURFACE; });
    }
    print_by_depth(out, "nodes by depth", cd->GetArray("depth"), [](vtkIdType) { return true; });
    print_arrays(out, cd);
}

}  // namespace

void vtk_info(const char *path, FILE *out)
{
    std::string type = xml_type(path);
    if (type == "UnstructuredGrid") {
        vtkNew<vtkXMLUnstructuredGridReader> r;
        read_xml(r.Get(), path);
        ug_info(out, path, "VTK UnstructuredGrid: surface leaves as voxels", r->GetOutput());
    } else if (type == "PUnstructuredGrid") {
        vtkNew<vtkXMLPUnstructuredGridReader> r;
        read_xml(r.Get(), path);
        std::string what = "VTK PUnstructuredGrid: the surface leaves of " +
                           std::to_string(r->GetNumberOfPieces()) + " pieces";
        ug_info(out, path, what.c_str(), r->GetOutput());
    } else if (type == "HyperTreeGrid") {
        vtkNew<vtkXMLHyperTreeGridReader> r;
        read_xml(r.Get(), path);
        htg_info(out, path, "VTK HyperTreeGrid: octree cells", r->GetOutput());
    } else if (type == "PHyperTreeGrid") {
        vtkNew<vtkXMLPHyperTreeGridReader> r;
        read_xml(r.Get(), path);
        std::string what = "VTK PHyperTreeGrid: the octree cells of " +
                           std::to_string(r->GetNumberOfPieces()) + " pieces";
        htg_info(out, path, what.c_str(), r->GetOutput());
    } else if (type == "PolyData") {
        vtkNew<vtkXMLPolyDataReader> r;
        read_xml(r.Get(), path);
        vtkPolyData *pd = r->GetOutput();
        std::fprintf(out, "file:     %s (VTK PolyData: a mesh)\n", path);
        print_field_data(out, pd->GetFieldData());
        std::fprintf(out, "points:   %lld\n", (long long)pd->GetNumberOfPoints());
        std::fprintf(out, "polygons: %lld\n", (long long)pd->GetNumberOfPolys());
    } else {
        throw Error(std::string("cannot read ") + path +
                    (type.empty() ? ": not a VTK XML file"
                                  : ": VTK " + type + " files are not ones ivoct writes"));
    }
}

}  // namespace ivexp
