// ivoct export/ — the VTK side: .vtp meshes, and reading the VTK files back
// (.vtu, .pvtu, .htg, .phtg, .vtp) for `ivoct info`.  The .vtu and the .htg
// are written by vtu_xml.cpp and htg_xml.cpp, without VTK's writers.
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
#include <vtkUnstructuredGrid.h>
#include <vtkXMLHyperTreeGridReader.h>
#include <vtkXMLPHyperTreeGridReader.h>
#include <vtkXMLPUnstructuredGridReader.h>
#include <vtkXMLPolyDataReader.h>
#include <vtkXMLPolyDataWriter.h>
#include <vtkXMLUnstructuredGridReader.h>

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

}  // namespace

// ---- .vtu: vtu_xml.cpp (VTK's UnstructuredGrid XML format, written without VTK's writer) ----
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
